# Calibration campaign of seed 000: dual-encoder ultra-precision rotary table.
# Copy and adapt:  make -f sjtu-dual.mk RIG=my-table.toml OUT=results/2026-11
# Each target is one enc command; make reruns only what is out of date, and a failed
# step leaves no half-written file behind.
ENC ?= enc
RIG ?= sjtu-dual
OUT ?= out
# the laboratory's certificate fields (enc-certificate(5)); copy it beside this file
CERT ?= $(dir $(lastword $(MAKEFILE_LIST)))sjtu-dual-certificate.toml

.PHONY: all
all: $(OUT)/report.html $(OUT)/design.txt $(OUT)/p-error.parquet $(OUT)/signals.parquet
	@$(ENC) report -q $(OUT)/grad.parquet $(OUT)/h-p.parquet $(OUT)/interp.parquet

# 1. Continuous run: 20 r at 1 r/min, all nine heads (seed 000 sec. 3.2) every 5.05 ms, the
#    rig's interval: the paper's 3 ms is 9 signal periods of encoder I per sample at the
#    nominal speed (stroboscopic unless the drive's speed error moves the alias out of the
#    band, as the rig's does; enc compare warns otherwise); add --interval 0.003 for it
$(OUT)/raw.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) -o $@ --force

# 2. Self-calibration of encoder II: four-head error separation (eqs. 11-18) gives the
#    graduation error (harmonics 1..100) and the spindle's radial error motion x, y
$(OUT)/grad.parquet: $(OUT)/raw.parquet
	$(ENC) selfcal $< --method esa --ref-head H1 --heads H5,H6,H7 \
	    --spectrum $(OUT)/grad-spectrum.parquet -o $@ --force

# 3. Multi-head averages H = mean(H1..H4), P = mean(P1, P2) (eqs. 3-6)
$(OUT)/avg.parquet: $(OUT)/raw.parquet
	$(ENC) average-heads $< -o $@ --force

# 4. Direct comparison of the two encoders, 100 harmonics, 20 revolutions (eq. 10). P is
#    used as it reads, as the paper does: the certificate's U holds its whole error, the
#    rig's bound of encoder I (reference_encoder_uncorrected, 0.37": U 0.42"). With
#    --reference-curve FILE (encoder I's calibrated curve) the row would be that
#    calibration's U instead (enc-rig(5))
$(OUT)/h-p.parquet: $(OUT)/avg.parquet
	$(ENC) compare $< --device H --reference P -o $@ --force

# 5. Encoder I's own error: H corrected with the self-calibrated curve (fig. 8)
$(OUT)/p-error.parquet: $(OUT)/avg.parquet $(OUT)/grad.parquet
	$(ENC) compare $< --device P --reference H --reference-curve $(OUT)/grad.parquet --name P \
	    -o $@ --force

# 6. What the 0/60/135/228 deg arrangement can recover (|W(n)|, blind harmonics)
$(OUT)/design.txt:
	@mkdir -p $(OUT)
	$(ENC) design --angles 0,60,135,228 --band 100 > $@

# 7. Interpolation error: 25" at 0.5" from 60 deg, probes at L = 200 mm (table 1, sec. 4)
$(OUT)/sweep.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) --mode sweep -o $@ --force

$(OUT)/interp.parquet: $(OUT)/sweep.parquet
	$(ENC) interp-check $< --spectrum $(OUT)/interp-harmonics.parquet -o $@ --force

# 8. H1, H2 against P1 (another signal period), 1st/2nd harmonics kept (figs. 12-15)
$(OUT)/interp-by-p1.parquet: $(OUT)/sweep.parquet
	$(ENC) interp-check $< --heads H1,H2 --reference P1 -o $@ --force

# 9. H1's interpolation error from a continuous run instead of a sweep: 0.5 deg windows,
#    each with its own trend, the harmonics shared; streamed in constant memory
$(OUT)/interp-run.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) --heads H1,P1 | $(ENC) interp-check --reference P1 -o $@ --force

# 10. Signal quality from raw sin/cos (Heydemann), and the readings corrected with it
$(OUT)/sweep-signals.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) --mode sweep --signals -o $@ --force

$(OUT)/signals.parquet: $(OUT)/sweep-signals.parquet
	$(ENC) interp-check $< --signals --corrected $(OUT)/sweep-corrected.parquet \
	    -o $@ --force

# 11. ISO 230-2 of the rotary axis: 8 targets, 5 runs in each direction, 2 readings a
#     stop; the axis positions on encoder II and the step run is read on encoder I, its
#     reference instrument (enc report: ISO 230-2 and the budget per target)
$(OUT)/steps.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) --mode steps --count 8 --runs 5 --bidirectional \
	    --readings 2 -o $@ --force

# 12. The calibration certificate: text on stdout, HTML and A4 PDF for the customer, and
#     the laboratory's record of how it was made (inputs, commands, versions)
$(OUT)/report.html: $(OUT)/grad.parquet $(OUT)/h-p.parquet $(OUT)/interp.parquet \
                    $(OUT)/interp-by-p1.parquet $(OUT)/interp-run.parquet \
                    $(OUT)/steps.parquet $(CERT)
	$(ENC) report $(OUT)/grad.parquet $(OUT)/grad-spectrum.parquet $(OUT)/h-p.parquet \
	    $(OUT)/interp.parquet $(OUT)/interp-by-p1.parquet $(OUT)/interp-run.parquet \
	    $(OUT)/steps.parquet \
	    --title "Rotary table $(RIG): graduation, radial motion, interpolation, positioning" \
	    --certificate $(CERT) --html $@ --pdf $(OUT)/report.pdf \
	    --record $(OUT)/report-record.txt --force > $(OUT)/report.txt

# Calibration campaign of seed 001: 23-bit reference encoder, polygon, RBF model, ROM.
# Copy and adapt:  make -f ciomp-23bit.mk RIG=my-encoder.toml OUT=results/unit-0042
ENC ?= enc
RIG ?= ciomp-23bit
OUT ?= out
# the laboratory's certificate fields (enc-certificate(5)); copy it beside this file
CERT ?= $(dir $(lastword $(MAKEFILE_LIST)))ciomp-23bit-certificate.toml
# the reference a dense run is checked against (truth: the simulator's motion; a real
# rig: the heads of a reference encoder, e.g. R1,R2) and the s it must reach [arcsec]
REF ?= truth
MAX_STD ?= 0.65

.PHONY: all
all: $(OUT)/report.html $(OUT)/correction.mif $(OUT)/correction.bin $(OUT)/ENC_COMP.SPF \
     $(OUT)/joint.comp $(OUT)/latency.txt $(OUT)/residual.parquet $(OUT)/points-certified.parquet
	@$(ENC) report -q $(OUT)/points.parquet $(OUT)/model.parquet

# 1. Readout latency: dynamic error and code-skip speed (eqs. 1-4) at 1 and 10 r/s
$(OUT)/latency.txt:
	@mkdir -p $(OUT)
	$(ENC) latency --bits 23 --delay 10e-6 --speeds 60,600 > $@

# 2. 24-face polygon + autocollimator: 24 positions every 15 deg, 5 readings each (sec. 5.3)
$(OUT)/polygon.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) --mode steps -o $@ --force

# 3. Calibration points (table 1)
$(OUT)/points.parquet: $(OUT)/polygon.parquet
	$(ENC) points $< -o $@ --force

# 3b. No certified polygon: polygon and encoder calibrate each other by closure (the
#     polygon turned by a face between 24 runs, 576 positions; enc-closure(1)); its face
#     errors are the polygon's certificate from then on
.PHONY: closure
closure: $(OUT)/polygon-faces.csv

$(OUT)/polygon-faces.csv:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) --mode closure -o $(OUT)/closure.parquet --force
	$(ENC) closure $(OUT)/closure.parquet -o $(OUT)/closure-points.parquet --faces-out $@ --force

$(OUT)/points-certified.parquet: $(OUT)/polygon.parquet $(OUT)/polygon-faces.csv
	$(ENC) points $< --polygon-certificate $(OUT)/polygon-faces.csv -o $@ --force

# 4. RBF network through the points (eqs. 5-7), leave-one-out residuals (sec. 5.4)
$(OUT)/model.parquet: $(OUT)/points.parquet
	$(ENC) fit-rbf $< -o $@ --force

# 5. Full 23-bit correction ROM in 16-bit words: FPGA init file and raw image, read back
$(OUT)/correction.mif: $(OUT)/model.parquet
	$(ENC) make-rom $< --width 16 --verify -o $@ --force

$(OUT)/correction.bin: $(OUT)/model.parquet
	$(ENC) make-rom $< --width 16 --verify -o $@ --force

# 5b. The same words as a correction-table stream, for the certificate: its quantisation
#     (half an LSB) is a term of the U of the correction the item ships with
$(OUT)/rom.parquet: $(OUT)/model.parquet
	$(ENC) make-rom $< --width 16 -o $@ --force

# 6. A 256-point table for a SINUMERIK rotary axis (0..360 deg, both ends present) at the
#    control's resolution (1 / MD10210 INT_INCR_PER_DEG), and a LinuxCNC joint
#    compensation file from the points themselves (one point per polygon face)
$(OUT)/ENC_COMP.SPF: $(OUT)/model.parquet
	$(ENC) make-rom $< --address-bits 8 --axis C1 --resolution 0.0001 --verify -o $@ --force

$(OUT)/joint.comp: $(OUT)/points.parquet
	$(ENC) make-rom $< --target linuxcnc --verify -o $@ --force

# 6b. The ROM applied to a dense turn as the FPGA would (look-up by code, words added):
#     the error before and after (seed 001 tables 1-2: s 1.30" -> 0.50"); exit 1 above MAX_STD.
#     The raw image too, which states no layout (the run's rig gives the code's bits): the
#     same corrected turn as the MIF's
$(OUT)/residual.parquet: $(OUT)/correction.mif $(OUT)/correction.bin
	$(ENC) acquire --rig $(RIG) --mode continuous --revolutions 1 -o $(OUT)/dense.parquet --force
	$(ENC) correct $(OUT)/dense.parquet --table $< --reference $(REF) --max-std $(MAX_STD) -o $@ --force
	$(ENC) correct $(OUT)/dense.parquet --table $(OUT)/correction.bin --reference $(REF) \
	    --max-std $(MAX_STD) -o $(OUT)/residual-bin.parquet --force

# 7. The calibration certificate: text on stdout, HTML and A4 PDF for the customer (its
#    conformity to the specification the certificate file names: p-p at most 5"), and
#    the laboratory's record of how it was made (inputs, commands, versions); the
#    correction table among its inputs (the ROM's words: 2^23 of them, read a block at a time)
$(OUT)/report.html: $(OUT)/points.parquet $(OUT)/model.parquet $(OUT)/rom.parquet $(CERT)
	$(ENC) report $(OUT)/points.parquet $(OUT)/model.parquet $(OUT)/rom.parquet --certificate $(CERT) \
	    --title "Encoder $(RIG): polygon calibration and RBF model" --max-pp 5 \
	    --html $@ --pdf $(OUT)/report.pdf --record $(OUT)/report-record.txt \
	    --force > $(OUT)/report.txt

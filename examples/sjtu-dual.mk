# Calibration campaign of seed 000 (dual-encoder rotary table) — copy and adapt.
#   make -f sjtu-dual.mk RIG=my-table.toml OUT=results/2026-11
# Each step is one enc command; make reruns only what is out of date.
ENC ?= enc
RIG ?= sjtu-dual
OUT ?= out

.PHONY: all
all: $(OUT)/raw.parquet $(OUT)/sweep.parquet
	@$(ENC) info $(OUT)/raw.parquet
	@$(ENC) info $(OUT)/sweep.parquet

# 20 revolutions at 1 r/min, every head sampled every 3 ms (the rig's defaults)
$(OUT)/raw.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) -o $@ --force

# interpolation check: 25" at 0.5" steps from 60 deg, probes and all heads (seed 000 table 1)
$(OUT)/sweep.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) --mode sweep -o $@ --force

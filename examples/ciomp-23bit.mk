# Calibration campaign of seed 001 (23-bit reference encoder, polygon + ROM) — copy and adapt.
#   make -f ciomp-23bit.mk RIG=my-encoder.toml OUT=results/unit-0042
ENC ?= enc
RIG ?= ciomp-23bit
OUT ?= out

.PHONY: all
all: $(OUT)/polygon.parquet
	@$(ENC) info $(OUT)/polygon.parquet

# 24-face polygon + autocollimator: 24 positions every 15 deg, 5 readings each
$(OUT)/polygon.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) --mode steps -o $@ --force

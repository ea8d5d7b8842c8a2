# A nightly recheck campaign of your own for enc-nightly(1), seed 000's rig: two turns
# self-calibrated, the graduation error as the night's result. enc-nightly sets RIG
# and OUT (a fresh folder) and reads $(OUT)/result.parquet:
#   enc-nightly --rig sjtu-dual --history h --calibration cal.parquet \
#       --campaign 'make -f examples/nightly-campaign.mk RIG="$RIG" OUT="$OUT"'
ENC ?= enc
RIG ?= sjtu-dual
OUT ?= out

$(OUT)/result.parquet:
	@mkdir -p $(OUT)
	$(ENC) acquire --rig $(RIG) --revolutions 2 | $(ENC) selfcal -q -o $@

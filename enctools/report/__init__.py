"""Calibration reports: figures, ISO 230-2, VDI/DGQ 3441, thresholds, history, text/JSON/HTML/PDF.

- :mod:`.figures`: p-p, +/-, mean, Bessel standard deviation (seed 001 eq. (8)),
  harmonics, expanded uncertainty U (k = 2).
- :mod:`.iso230`: ISO 230-2 figures of a bidirectional step run (B, R, E, M, A).
- :mod:`.vdi3441`: VDI/DGQ 3441 figures of the same runs (P, Pa, Ps, U).
- :mod:`.sections`: one section per stream kind, built from a stream's header and table.
- :mod:`.summary`: the report of several inputs (sections + comparisons).
- :mod:`.text`, :mod:`.jsonout`, :mod:`.html`, :mod:`.pdf`, :mod:`.plots`: renderings.
- :mod:`.thresholds`: the cron contract (``max_pp`` ...).
- :mod:`.history`: the nightly history dataset (one Parquet file per run, in the Hive
  partitions of :mod:`.partitions`).
"""

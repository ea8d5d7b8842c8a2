"""The calibration methods of the two seeds, over numpy arrays (and streams of batches).

- :mod:`.harmonics`: Fourier coefficients of a revolution on an uneven grid, synthesis.
- :mod:`.heads`: multi-head averaging and its transfer function A(n) (seed 000 eqs. 3-6).
- :mod:`.selfcal`: Fourier self-calibration and four-head error separation (eqs. 11-18);
  :mod:`.design`: what a head arrangement can recover.
- :mod:`.compare`: direct comparison of a device against a reference (eqs. 7-10).
- :mod:`.interp`: interpolation error within a signal period (seed 000 sec. 4), with
  :mod:`.heydemann` (ellipse fit of raw sin/cos) and :mod:`.trend_lsq`.
- :mod:`.latency`: readout latency's dynamic error and code skip (seed 001 eqs. 1-4).
- :mod:`.points`: calibration points from step runs and tables (seed 001 sec. 5).
"""

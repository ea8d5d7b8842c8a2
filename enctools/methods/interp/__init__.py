"""Interpolation error: the deviation of a head within its signal period (seed 000 sec. 4).

A small-angle sweep (seed 000 table 1: 7.2" at 0.2" steps, 25" at 0.5") or a
continuous run records a device head (or a head average) and a reference at once;
the device's error is fitted as harmonics of its signal phase. One module per job:

- :mod:`.settings`: :class:`Settings`, the options of a check, resolved and checked;
- :mod:`.model`: the harmonics of a period, their design columns and least squares;
- :mod:`.coverage`: how well the samples cover the signal period;
- :mod:`.fit`: the fit against a reference, fed batch by batch;
- :mod:`.bank`: the fits of the heads of a run against one reference, fed as one;
- :mod:`.reference`: the references (probes, another head, a time-matched file);
- :mod:`.readings`: a readings stream's heads checked against a reference;
- :mod:`.signals`: the error from the heads' raw signals (Heydemann);
- :mod:`.screen`: their faults (clipping, radius outliers, a missing quadrant) kept out;
- :mod:`.curve`, :mod:`.tables`: the result curves, the Arrow plumbing;
- :mod:`.check`: one check as the command runs it (:func:`.check.run`).
"""

from enctools.methods.interp.settings import Settings

__all__ = ["Settings"]

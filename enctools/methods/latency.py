"""Readout latency of an encoder: dynamic error and code skipping (seed 001 sec. 2).

An encoder that needs t_d = t_A/D + t_m to turn its signals into a reading
(seed 001 eq. 1) reports, at angular speed v, an angle late by

    mu_1 = t_d * v                                   (seed 001 eq. 2)

Its resolution is delta = 360 deg / 2**n (eq. 3); above

    v = 360 deg / (2**n * t_d)                       (seed 001 eq. 4)

the lag exceeds one code and codes are skipped. The lag of a real encoder is
measured from continuous runs against a reference angle (a reference encoder, or
the simulator's true motion): the mean of device minus reference over whole turns
is ``offset - v * t_d``; one run gives t_d when the offset is known to be zero,
runs at two or more speeds give both.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from enctools.errors import DataError
from enctools.units import ARCSEC, DEG, TWO_PI, factor


def readout_delay(t_ad_s: float, t_m_s: float) -> float:
    """t_d = t_A/D + t_m [s] (seed 001 eq. 1)."""
    return t_ad_s + t_m_s


def resolution_deg(bits: int) -> float:
    """delta = 360 / 2**n [deg] (seed 001 eq. 3)."""
    return 360.0 / 2.0 ** bits


def dynamic_error_deg(latency_s: float, speed_deg_s: np.ndarray | float) -> np.ndarray | float:
    """mu_1 = t_d * v [deg] at speed v [deg/s] (seed 001 eq. 2)."""
    return latency_s * np.asarray(speed_deg_s) if np.ndim(speed_deg_s) else latency_s * speed_deg_s


def code_skip_speed_deg_s(bits: int, latency_s: float) -> float:
    """v = 360 / (2**n t_d) [deg/s] above which codes are skipped (seed 001 eq. 4)."""
    if not latency_s > 0:
        msg = f"the readout delay must be > 0 s, not {latency_s}"
        raise DataError(msg)
    return 360.0 / (2.0 ** bits * latency_s)


@dataclass(frozen=True)
class RunLag:
    """One continuous run against its reference."""

    speed_deg_s: float
    mean_difference_arcsec: float  # device - reference over whole turns
    turns: float
    samples: int


def run_difference(t: np.ndarray, device_rad: np.ndarray, reference_rad: np.ndarray) -> RunLag:
    """Speed [deg/s] and mean device - reference [arcsec] over whole turns of a run.

    ``device_rad`` and ``reference_rad`` are unwrapped angles [rad] at times ``t``
    [s]. Averaging over whole turns removes the periodic errors (graduation,
    interpolation) and leaves ``offset - v * t_d``.
    """
    t = np.asarray(t, dtype=np.float64)
    ref = np.asarray(reference_rad, dtype=np.float64)
    dev = np.asarray(device_rad, dtype=np.float64)
    if t.size < 3:
        msg = "a continuous run needs at least 3 samples to measure a lag"
        raise DataError(msg)
    omega = np.polyfit(t - t[0], ref, 1)[0]  # rad/s
    if abs(omega) * (t[-1] - t[0]) < 1e-9:
        msg = "the reference does not move: a lag needs a run at a known, non-zero speed"
        raise DataError(msg)
    travel = np.abs(ref - ref[0])
    turns = float(np.floor(travel[-1] / TWO_PI))
    sel = travel < turns * TWO_PI if turns >= 1 else np.ones(t.size, bool)
    diff = (dev[sel] - ref[sel]) / ARCSEC
    return RunLag(float(omega / DEG), float(diff.mean()), float(travel[-1] / TWO_PI),
                  int(sel.sum()))


def lag_from_runs(runs: list[RunLag], offset_arcsec: float | None = 0.0
                  ) -> tuple[float, float]:
    """Readout lag t_d [s] and zero offset [arcsec] from one or more runs.

    One run (or ``offset_arcsec`` given): t_d = -(mean - offset) / v. Several runs
    at different speeds and ``offset_arcsec=None``: least squares of mean = offset
    - v t_d.
    """
    v = np.array([r.speed_deg_s for r in runs]) * factor("deg", "arcsec")  # arcsec/s
    m = np.array([r.mean_difference_arcsec for r in runs])
    if offset_arcsec is None:
        if np.ptp(v) < 1e-9 * max(np.abs(v).max(), 1.0):
            msg = "runs at different speeds are needed to separate lag and offset"
            raise DataError(msg)
        slope, offset = np.polyfit(v, m, 1)
        return float(-slope), float(offset)
    return float(np.sum(-(m - offset_arcsec) * v) / np.sum(v * v)), float(offset_arcsec)

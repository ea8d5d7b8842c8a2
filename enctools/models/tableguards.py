"""What enc make-rom refuses to write: a model that does not help, a table whose rounding
leaves an error of the order of the correction, a table of zeros.

Each check returns the one line that says what is wrong and by which figures, or None;
:func:`enforce` raises it (exit 2) or, when the user's override allows it, hands it
back to be warned. The figures:

- gain: the model stream's ``residuals.gain`` (enc fit-rbf; :mod:`enctools.models.gain`),
  or for an older stream the same test from its points' Bessel s and leave-one-out RMS.
- quantisation: RMS over the table of (stored - exact correction) against the RMS of
  the exact correction; over :data:`QUANTISATION_LIMIT` of it is refused. A table
  whose every stored value is 0 is refused with its largest correction against the
  step (LSB or the control's resolution).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from enctools.errors import DataError
from enctools.models import gain as gains
from enctools.units import factor

#: the largest RMS quantisation error a table may carry, as a fraction of the RMS of the
#: correction it stores (dimensionless)
QUANTISATION_LIMIT = 0.25
#: the settings that let a refused table be written, as a message names them
ALLOW_NO_GAIN = "`allow_no_gain`"
ALLOW_COARSE = "`allow_coarse`"


def enforce(problem: str | None, allowed: bool, option: str) -> str | None:
    """Raise DataError (exit 2) with ``problem`` unless ``allowed``; return it (to be
    warned) when allowed, None when there is no problem."""
    if problem is None:
        return None
    if not allowed:
        msg = f"{problem}; {option} writes it anyway"
        raise DataError(msg)
    return f"{problem} (written: {option})"


def gain_problem(meta: dict[str, Any]) -> str | None:
    """Why the model a stream's metadata describes does not help, or None (it helps, or
    the stream records nothing to judge it by: a deviations stream, a step run)."""
    if "residuals" not in meta:
        return None
    g = gains.from_residuals(meta["residuals"])
    if g is None or g.get("helps"):
        return None
    return f"{gains.refusal(g)} (enc-fit-rbf(1), GAIN)"


def quantisation_problem(rms_correction: float, rms_error: float, largest: float,
                         step_arcsec: float, all_zero: bool, what: str) -> str | None:
    """Why a table's rounding is too coarse for its correction, or None.

    rms_correction, rms_error, largest : the exact correction's RMS, the RMS of (stored
    - exact) and the largest |exact correction| over the table [arcsec]; step_arcsec :
    one stored step [arcsec]; what : the step's name (``the LSB``, ``fanuc's resolution``).
    """
    if all_zero and largest > 0:
        return (f"every entry rounds to 0: the largest correction {largest:.4g}\" is under "
                f"half of {what} {step_arcsec:.4g}\"")
    if rms_correction > 0 and rms_error > QUANTISATION_LIMIT * rms_correction:
        return (f"{what} {step_arcsec:.4g}\" leaves a quantisation error of RMS "
                f"{rms_error:.4g}\" against the correction's RMS {rms_correction:.4g}\" "
                f"(over {QUANTISATION_LIMIT:g} of it)")
    return None


def rom_problem(rom: Any) -> str | None:
    """:func:`quantisation_problem` of a memory table (:class:`enctools.models.rom.Rom`)."""
    lsb = rom.spec.lsb_arcsec
    return quantisation_problem(rom.rms_correction_lsb * lsb, rom.rms_quantisation_lsb * lsb,
                                rom.max_abs_correction_lsb * lsb, lsb,
                                rom.min_value == 0 == rom.max_value, "the LSB")


def control_problem(table: Any) -> str | None:
    """:func:`quantisation_problem` of a control's table
    (:class:`enctools.models.romformats.controls.ControlTable`), over its points and
    both directions when it has two."""
    step = table.resolution_deg * factor("deg", "arcsec")
    sign = table.settings.stored_sign
    rad = factor("rad", "arcsec")
    pairs = [(table.intended_forward_rad, table.forward)]
    if table.backward is not None and table.intended_backward_rad is not None:
        pairs.append((table.intended_backward_rad, table.backward))
    exact = np.concatenate([np.asarray(e, np.float64) * rad for e, _ in pairs])
    stored = np.concatenate([sign * np.asarray(v, np.float64) * step for _, v in pairs])
    return quantisation_problem(gains.rms(exact), gains.rms(stored - exact),
                                float(np.max(np.abs(exact), initial=0.0)), step,
                                not np.any(stored), f"{table.settings.target}'s resolution")

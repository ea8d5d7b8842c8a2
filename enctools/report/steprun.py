"""The positioning section of a step run: encoder - target per target, with ISO 230-2.

A step run of enc acquire (its steps mode) records, at each commanded target, the
heads of its encoders. The positioning deviation is the mean angle of the heads of the
encoder the axis does not position on (:mod:`enctools.report.positioning`) minus the
target [arcsec], its mean removed; :func:`positioning` gives it to the section as a
curve of targets with the figures of the report's standard and its uncertainty budget
(:func:`enctools.report.budget.step_run_into`). Values in arcsec.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from enctools.data.readings import HeadInfo
from enctools.report.budget import step_run_into
from enctools.report.positioning import Positioning, feedback_reason, servo_loop_note
from enctools.units import ARCSEC, DEG, TWO_PI


def positioning(s: Any, scan: Any, encoder: list[HeadInfo], opts: Any, where: Positioning,
                points_into: Callable[..., None]) -> None:
    """Positioning deviation of a step run into section ``s`` (a ``sections.Section``):
    mean angle of the encoder's heads - target, from the ``scan`` of its batches
    (``readingsscan.ReadingsScan``: targets and angles [rad], directions, runs); read on the
    axis' feedback encoder, no figures unless ``opts.servo_loop``. ``points_into``: the
    section's curve of targets (``sections._points_into``)."""
    target = np.concatenate(scan.target)
    angle = np.concatenate(scan.angle)
    dev = (np.mod(angle - target + np.pi, TWO_PI) - np.pi) / ARCSEC
    dev -= dev.mean()
    direction = np.concatenate(scan.direction) if scan.direction else None
    run = np.concatenate(scan.run) if scan.run else None
    no_iso = None
    if s.info.get("mode") == "sweep":
        no_iso = ("a sweep steps over a small range, not targets over the axis's travel "
                  f"(a full turn) as {opts.standard_name} asks")
    elif where.is_feedback and not opts.servo_loop:
        no_iso = opts.say(feedback_reason(where, scan.autocollimator))
    enc = encoder[0].encoder
    s.notes.append(f"positioning deviation = mean of heads {', '.join(i.name for i in encoder)} "
                   f"(encoder {enc}) - target, mean removed (head zeros are set below one "
                   "signal period)")
    points_into(s, target / DEG, dev, direction, opts, f"encoder {enc} - target",
                "positioning", tol_deg=1e-9, run=run, no_iso=no_iso)
    # its budget: the Type A over the approaches, the heads' rounding (a target whose
    # approaches read the same counts still has its U) and the reference's declarations
    lsb = TWO_PI / ARCSEC / min(i.counts_per_rev for i in encoder)     # arcsec
    step_run_into(s, lsb, len(encoder), enc, reference=not where.is_feedback)
    if where.is_feedback and (s.iso is not None or s.vdi is not None):
        s.notes.append(opts.say(servo_loop_note(where, opts.standard_name)))
    elif where.is_feedback and f"figures: {no_iso}" in " ".join(s.notes):
        logging.getLogger("enctools").warning("%s: no %s figures: %s", s.source,
                                              opts.standard_name, no_iso)

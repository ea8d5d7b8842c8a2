"""Which encoder a step run's positioning deviation is read on, and what its figures mean.

A motion axis closes its position loop on one encoder, its feedback (rig file
``motion.feedback``, enc-rig(5); the first encoder when the rig names none): it moves
until that encoder reads the target. "Feedback encoder - target" is then the servo
loop's residual, how closely the loop holds that encoder on the target; the encoder's
own graduation error, which is what the axis gets wrong, cannot appear in it. ISO 230-2
and VDI/DGQ 3441 figures of the axis need a measurement the loop does not close on: a
second encoder on the same axis, or a polygon and an autocollimator
(``enc points RUN | enc report``).

:func:`positioning_heads` picks the heads (the first recorded encoder that is not the
feedback, else the first encoder); :func:`feedback_reason` says why the figures of the
feedback encoder are not the axis'.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from enctools.data.readings import HeadInfo, rig_measure_heads


def feedback_encoder(meta: dict[str, Any]) -> str | None:
    """The encoder the axis positions on, as the rig recorded in a stream's metadata
    names it: ``motion.feedback``, else its first encoder (enc-rig(5)); None when the
    metadata holds no rig with encoders."""
    rig = meta.get("rig")
    if not isinstance(rig, dict):
        return None
    motion = rig.get("motion")
    if isinstance(motion, dict) and isinstance(motion.get("feedback"), str):
        return str(motion["feedback"])
    encoders = rig.get("encoders")
    if isinstance(encoders, list) and encoders and isinstance(encoders[0], dict):
        name = encoders[0].get("name")
        return str(name) if name is not None else None
    return None


@dataclass(frozen=True)
class Positioning:
    """The encoder whose heads' mean is the measured position of a step run, and the
    axis' feedback encoder (None: the stream does not say)."""

    encoder: str
    feedback: str | None

    @property
    def is_feedback(self) -> bool:
        """True when the position is read on the encoder the axis positions on."""
        return self.encoder == self.feedback

    def describe(self) -> str:
        """What the report says the positioning deviation is read on."""
        if self.feedback is None:
            return f"encoder {self.encoder} (the axis' feedback not recorded)"
        if self.is_feedback:
            return f"encoder {self.encoder}, the axis' feedback (the servo loop)"
        return f"encoder {self.encoder}, independent of the axis' feedback {self.feedback}"


def positioning_heads(infos: list[HeadInfo], meta: dict[str, Any]
                      ) -> tuple[list[HeadInfo], Positioning | None]:
    """The heads of a step run whose mean angle is its measured position: the measuring
    heads (the rig's ``measure_heads`` recorded, else every recorded head) of the first
    recorded encoder that is not the axis' feedback, else of the first encoder
    (:class:`Positioning` says which; None when no head is recorded)."""
    if not infos:
        return [], None
    feedback = feedback_encoder(meta)
    encoders = list(dict.fromkeys(i.encoder for i in infos))
    chosen = next((e for e in encoders if e != feedback), encoders[0])
    heads = [i for i in infos if i.encoder == chosen]
    measuring = set(rig_measure_heads(meta, chosen))
    return [i for i in heads if i.name in measuring] or heads, Positioning(chosen, feedback)


def feedback_reason(where: Positioning, has_autocollimator: bool) -> str:
    """Why a step run read on its feedback encoder has no positioning figures, with
    what gives them (one line, after "no ISO 230-2 figures: ")."""
    other = ("its polygon and autocollimator give the axis' figures (enc points RUN | "
             "enc report)" if has_autocollimator else
             "record a second encoder or a polygon with an autocollimator for the axis' figures")
    return (f"encoder {where.encoder} is the axis' feedback (rig motion.feedback): the axis "
            "moves until it reads the target, so encoder - target measures the servo loop, "
            f"not the axis; {other}; `servo_loop` gives the loop's figures")


def servo_loop_note(where: Positioning, standard: str) -> str:
    """The note of figures computed with ``servo_loop`` from the feedback encoder (the
    setting named as a field between backticks)."""
    return (f"{standard} figures of the servo loop (`servo_loop`): encoder {where.encoder} is "
            "the axis' feedback, so they say how closely the loop holds it on the target, "
            "not how well the axis positions")

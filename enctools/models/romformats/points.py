"""A motion control's compensation table as the control applies it: :class:`PointTable`.

Every reader of a control's table file (:mod:`.controlreaders`) gives one back, with
the control's own sign convention already resolved, so any table written can be
applied back to readings the same way whatever control it was written for:

    correction(angle) = linear interpolation of the points' corrections [rad]
    true angle        = indicated angle + correction

with the angle taken modulo ``modulo_rad`` when the table is periodic (a rotary axis
whose control wraps the table), and the end values held beyond the first and last
point otherwise (LinuxCNC). The correction is the value to ADD to the indicated
angle (minus the deviation "indicated - true" of enc-streams(5)); a control that
stores the error, or adds its value to the command, is converted by its reader.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PointTable:
    """A compensation table: corrections [rad] at increasing positions [rad].

    positions_rad : the table's points, strictly increasing [rad].
    forward_rad : the correction at each point when moving in the positive direction,
        and in both directions when ``backward_rad`` is None [rad].
    backward_rad : the correction at each point when moving in the negative direction
        (a bidirectional table), or None [rad].
    backlash_rad : a reversal value the control adds to the forward correction when
        moving in the negative direction (backward = forward + backlash_rad), or None [rad].
    modulo_rad : the period the control wraps positions into (2 pi for a rotary
        table), or None: no wrap, the end values are held beyond the ends [rad].
    """

    positions_rad: np.ndarray
    forward_rad: np.ndarray
    backward_rad: np.ndarray | None = None
    backlash_rad: float | None = None
    modulo_rad: float | None = None

    def __post_init__(self) -> None:
        p = np.asarray(self.positions_rad, dtype=np.float64)
        if p.ndim != 1 or p.size < 2 or not np.all(np.diff(p) > 0):
            msg = "a point table needs 2 or more strictly increasing positions"
            raise ValueError(msg)
        for name in ("forward_rad", "backward_rad"):
            v = getattr(self, name)
            if v is not None and np.asarray(v).shape != p.shape:
                msg = f"{name} has {np.asarray(v).size} values for {p.size} positions"
                raise ValueError(msg)

    def correction(self, angle_rad: np.ndarray | float, direction: np.ndarray | int = 1
                   ) -> np.ndarray:
        """The correction [rad] to add to indicated angles ``angle_rad`` [rad], moving in
        ``direction`` (+1 or -1, per angle or one for all)."""
        a = np.asarray(angle_rad, dtype=np.float64)
        p = np.asarray(self.positions_rad, dtype=np.float64)
        if self.modulo_rad is not None:
            a = p[0] + np.mod(a - p[0], self.modulo_rad)
        forward = np.interp(a, p, self.forward_rad)
        backward = (forward if self.backward_rad is None
                    else np.interp(a, p, self.backward_rad))
        if self.backlash_rad is not None:
            backward = backward + self.backlash_rad
        return np.where(np.asarray(direction) < 0, backward, forward)

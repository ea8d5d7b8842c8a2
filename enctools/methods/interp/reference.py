"""The references a device's interpolation error is measured against (seed 000 sec. 4).

One abstraction, :class:`Reference`: for a batch of readings it gives the
reference angle [rad] (and, for a head, its signal phase), and it names the
harmonics it brings of its own (those of its signal period, when it is a head).

- :class:`ProbeReference`: capacitive probes on an arm L, psi_R = side * h / L
  (seed 000 eq. (20)), the probes averaged (two probes on opposite sides cancel the
  spindle's translation); they bring no periodic error of their own.
- :class:`HeadReference`: another encoder's head in the same stream. When its
  signal period differs, its own interpolation error sits at other
  period-harmonics of the device (seed 000 figs. 12-14).
- :class:`TimeMatchedReference`: either of them recorded in another file, taken
  whole and interpolated to the input's times t.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.readings import HeadInfo, head_angle, head_info, signal_phase, signal_step
from enctools.data.schemas import columns_with_role, field_meta
from enctools.errors import DataError
from enctools.methods.interp.settings import Settings
from enctools.methods.interp.tables import column
from enctools.units import TWO_PI


@dataclass(frozen=True)
class ReferenceReading:
    """The reference over one batch of readings.

    ``angle_rad`` [rad] per row; ``phase_rad`` [rad] its signal phase (a head), or
    ``step`` [count] that phase in counts of ``steps`` per period when read from the
    counts (else None and 0; :meth:`phase` gives it either way); ``rows`` the rows of
    the batch it covers (None: all).
    """

    angle_rad: np.ndarray
    phase_rad: np.ndarray | None = None
    step: np.ndarray | None = None
    steps: int = 0
    rows: np.ndarray | None = None

    def phase(self) -> np.ndarray | None:
        """The signal phase [rad] (None: probes), from the step when not given."""
        if self.phase_rad is None and self.step is not None:
            return self.step * (TWO_PI / self.steps)
        return self.phase_rad


class Reference(ABC):
    """The angle a device is checked against, batch by batch.

    ``name``: "probes" or the head's name; ``meta``: a JSON-able description for the
    output's metadata; ``head``: the reference head, whose own interpolation error
    comes along at harmonics of its signal period (None for probes);
    ``in_stream``: read from the input's own rows (not matched from elsewhere).
    """

    name: str
    meta: dict[str, Any]
    head: HeadInfo | None = None
    in_stream: bool = True

    @abstractmethod
    def read(self, batch: pa.RecordBatch) -> ReferenceReading:
        """The reference at the rows of ``batch``."""

    @property
    def periods_per_rev(self) -> int | None:
        """Signal periods per revolution of its own interpolation error (None: probes)."""
        return None if self.head is None else self.head.periods_per_rev

    def other_period(self, periods_per_rev: int) -> bool:
        """Whether it brings harmonics of its own at other harmonics of a device's period.

        True for a head of another signal period than the device's ``periods_per_rev``:
        its error j cycles per own period lands at j * ratio of the device's.
        """
        return self.head is not None and self.head.periods_per_rev != periods_per_rev

    def finish(self) -> None:  # noqa: B027 (most references have nothing to check)
        """Check, at the end of the input, that the reference met it (DataError if not)."""


def probe_rotation(values: Sequence[np.ndarray], arms_m: Sequence[float],
                   sides: Sequence[int]) -> np.ndarray:
    """Rotation [rad] from displacement probes: mean of side * h / L (seed 000 eq. (20)).

    ``values`` [m] per probe, ``arms_m`` L [m], ``sides`` +1/-1. Two probes on
    opposite sides cancel the translation of the spindle.
    """
    if not values:
        msg = "no probe to use as the reference"
        raise DataError(msg)
    out = np.zeros(np.asarray(values[0]).shape)
    for h, arm, side in zip(values, arms_m, sides, strict=True):
        if not (np.isfinite(arm) and arm > 0):
            msg = f"probe arm length L = {arm!r} m: must be > 0 (psi = h / L)"
            raise DataError(msg)
        out += side * np.asarray(h, dtype=np.float64) / arm
    return out / len(values)


class ProbeReference(Reference):
    """Probes of the readings averaged (seed 000 eq. (20)); ``arm_m`` [m] overrides their L."""

    name = "probes"

    def __init__(self, schema: pa.Schema, probes: Sequence[str] | None,
                 arm_m: float | None) -> None:
        names = list(probes) if probes else columns_with_role(schema, "probe")
        if not names:
            msg = "input: no probe column (role=probe); give `reference` HEAD or `reference_file`"
            raise DataError(msg)
        arms, sides = [], []
        for p in names:
            if p not in schema.names or field_meta(schema.field(p)).get("role") != "probe":
                known = ", ".join(columns_with_role(schema, "probe")) or "none"
                msg = f"input: no probe {p!r} (probes: {known})"
                raise DataError(msg)
            fm = field_meta(schema.field(p))
            arm = float(arm_m) if arm_m is not None else float(fm.get("arm_m", "nan"))
            if not (np.isfinite(arm) and arm > 0):
                msg = f"probe {p}: arm length L = {arm:g} m; it must be > 0 (give `arm_m`)"
                raise DataError(msg)
            arms.append(arm)
            sides.append(int(float(fm.get("side", "1"))))
        self.probes, self.arms_m, self.sides = names, arms, sides
        self.meta = {"reference": "probes", "probes": names, "arm_m": arms, "sides": sides}

    def angle(self, table: pa.Table | pa.RecordBatch) -> np.ndarray:
        """The probes' rotation [rad] at every row of ``table``."""
        return probe_rotation([column(table, p) for p in self.probes], self.arms_m, self.sides)

    def read(self, batch: pa.RecordBatch) -> ReferenceReading:
        return ReferenceReading(self.angle(batch))


class HeadReference(Reference):
    """A head of another encoder (or of the same) in the readings."""

    def __init__(self, info: HeadInfo) -> None:
        self.info = info
        self.head = info
        self.name = info.name
        self.meta = {"reference": info.name, "reference_encoder": info.encoder,
                     "reference_periods_per_rev": info.periods_per_rev}

    def angle(self, table: pa.Table | pa.RecordBatch) -> np.ndarray:
        """The head's reading [rad] at every row of ``table``."""
        return head_angle(column(table, self.name), self.info)

    def read(self, batch: pa.RecordBatch) -> ReferenceReading:
        info = self.info
        counts = column(batch, self.name)
        # the phase from the step only when asked for (ReferenceReading.phase)
        return ReferenceReading(head_angle(counts, info), None, signal_step(counts, info),
                                info.interpolation)


class TimeMatchedReference(Reference):
    """A reference recorded apart (``table``, whole), interpolated to the input's times t [s].

    ``within``: the probes or head of ``table``; ``source`` names the file in messages.
    """

    in_stream = False

    def __init__(self, within: ProbeReference | HeadReference, table: pa.Table,
                 source: str) -> None:
        self.name, self.head, self.source = within.name, within.head, source
        self.meta = within.meta | {"file": source}
        values = [within.angle(table)]
        if self.head is not None:
            values.append(np.unwrap(signal_phase(column(table, self.name), self.head)))
        order = np.argsort(column(table, "t"), kind="stable")
        self.t = np.asarray(column(table, "t"), float)[order]
        self.values = [np.asarray(v, float)[order] for v in values]
        self.rows = 0
        self.t_lo, self.t_hi = np.inf, -np.inf

    def read(self, batch: pa.RecordBatch) -> ReferenceReading:
        t = column(batch, "t")
        if t.size:
            self.t_lo = min(self.t_lo, float(np.min(t)))
            self.t_hi = max(self.t_hi, float(np.max(t)))
        inside = (t >= self.t[0]) & (t <= self.t[-1])
        self.rows += int(inside.sum())
        values = [np.interp(t, self.t, v) for v in self.values]
        phase = np.mod(values[1], TWO_PI) if self.head is not None else None
        return ReferenceReading(values[0], phase, rows=inside)

    def finish(self) -> None:
        if self.rows == 0:
            msg = (f"{self.source}: covers t = {self.t[0]:.6g}..{self.t[-1]:.6g} s, the input "
                   f"{self.t_lo:.6g}..{self.t_hi:.6g} s: no overlap in time")
            raise DataError(msg)


def open_reference(schema: pa.Schema, settings: Settings,
                   table: pa.Table | None = None) -> Reference:
    """The reference ``settings`` name, in the input (``schema``) or in ``table``.

    ``table``: the whole reference file (``settings.reference_file``), matched to the
    input by time; both need a column t. DataError when the probes or the head are
    not there.
    """
    source = settings.reference_file or "reference"
    where = schema if table is None else table.schema
    within: ProbeReference | HeadReference
    if settings.reference == "probes":
        within = ProbeReference(where, settings.probes, settings.arm_m)
    else:
        within = HeadReference(head_info(where, settings.reference,
                                         "input" if table is None else source))
    if table is None:
        return within
    if "t" not in schema.names or "t" not in table.schema.names:
        msg = f"{source}: both streams need a time column t to be matched"
        raise DataError(msg)
    return TimeMatchedReference(within, table, source)

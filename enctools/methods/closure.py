"""The closure (cross-calibration) of a polygon and a rotary table or encoder: both
calibrated at once, neither known beforehand (enc-closure(1)).

The polygon of F faces is measured at the F table positions j * 360/F, once in each of
F settings on the table, turned by one face between settings (enc acquire's closure
mode: run s is setting s), so that at table position j the autocollimator sees face
f = (j + s) mod F. With I the encoder's reading [rad] and A the autocollimator's
[arcsec] at (s, j)::

    y[s, j] = (I - j * 360/F) - A = e[j] + d[f] + b[s] + noise        [arcsec]

e the encoder's deviation (indicated - true angle) at position j, d the face angle
error of face f (enctools.data.polygon's convention), b a constant of each setting (the
polygon's offset as set on the table, the autocollimator's and encoder's zero). The
circle closes for both circles: the face errors sum to zero by definition, and the
encoder's deviation is taken relative to position 0, as enc points takes it. The
F x F design is a Latin square (rows s, columns j, faces f each once per row and
column), so the least-squares estimates are its margins (the method of the "dual
closure" of W. T. Estler, J. Res. NIST 103 (1998) 141-151): e from the column means,
d from the means over each face, b from the row means; the residuals, with
(F - 1)(F - 2) degrees of freedom, give the standard deviation s of one y and so the
standard uncertainties u(e[j] - e[0]) = s sqrt(2/F), u(d[f]) = s sqrt(F - 1)/F.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from enctools.data.statistics import figures_or_nan
from enctools.errors import DataError
from enctools.methods.points import Points, Settings, figures_meta, points_schema, step_visits
from enctools.units import ARCSEC, DEG, TWO_PI

if TYPE_CHECKING:
    import pyarrow as pa

    from enctools.data.streams import Header, InputStream

#: one-reading batches gathered before they are joined into one array per column: a
#: stream of many small batches (enc acquire writes one a reading) is held as a few
#: contiguous arrays, not as every batch with its per-array overhead [batches]
JOIN_EVERY = 4096


@dataclass(frozen=True)
class Separation:
    """What a closure separates [arcsec]: the encoder's deviation at each table position
    relative to position 0, the face angle errors (summing to zero), the settings'
    constants, the residuals, and their standard deviation with its degrees of freedom.
    """

    deviation: np.ndarray
    face_error: np.ndarray
    setting: np.ndarray
    residual: np.ndarray
    s: float
    dof: int

    @property
    def faces(self) -> int:
        return int(self.face_error.size)

    @property
    def u_deviation(self) -> float:
        """Standard uncertainty of each deviation e[j] - e[0], j > 0 [arcsec]."""
        return self.s * math.sqrt(2.0 / self.faces)

    @property
    def u_face(self) -> float:
        """Standard uncertainty of each face angle error [arcsec]."""
        return self.s * math.sqrt(self.faces - 1.0) / self.faces

    def meta(self) -> dict[str, Any]:
        """The ``closure`` metadata of the points."""
        return {"faces": self.faces, "settings": self.faces, "s_arcsec": self.s,
                "dof": self.dof, "u_deviation_arcsec": self.u_deviation,
                "u_face_arcsec": self.u_face,
                "face_error_arcsec": [float(x) for x in self.face_error],
                "setting_arcsec": [float(x) for x in self.setting]}


def separate(y: np.ndarray) -> Separation:
    """Encoder deviations and face errors from ``y[s, j]`` [arcsec] (the module's model).

    y : F x F, row s the polygon's setting, column j the table position; face
        (j + s) mod F seen at (s, j). F >= 3 (the residuals then have 2 degrees of
        freedom or more).
    """
    n = y.shape[0]
    if y.shape != (n, n) or n < 3:
        msg = f"a closure needs F x F readings with F >= 3, not {y.shape}"
        raise ValueError(msg)
    s_idx, j_idx = np.indices(y.shape)
    face = (j_idx + s_idx) % n
    mean = float(y.mean())
    col = y.mean(axis=0) - mean
    row = y.mean(axis=1) - mean
    by_face = np.bincount(face.ravel(), y.ravel(), n) / n - mean
    residual = y - mean - col[None, :] - row[:, None] - by_face[face]
    dof = (n - 1) * (n - 2)
    s = float(np.sqrt(np.sum(residual**2) / dof))
    return Separation(col - col[0], by_face, row + mean + col[0], residual, s, dof)


def _require_closure(header: Header, source: str) -> None:
    """DataError unless the readings are a closure run (enc acquire's closure mode)."""
    if header.meta.get("mode") != "closure":
        msg = (f"{source}: not a closure run (mode {header.meta.get('mode', 'continuous')!r}); "
               "make one with enc acquire in closure mode")
        raise DataError(msg)


def closure_matrix(header: Header, table: pa.Table, settings: Settings, source: str
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``y[s, j]`` [arcsec] of a closure run and the mean indicated angle of each table
    position [deg, 0..360).

    Every setting (run) must have visited every table position (step) once, in one
    direction; the encoder reading is the mean of the measuring heads, the
    autocollimator's the mean of the position's readings.
    """
    _require_closure(header, source)
    faces, (angle, ac, run, direction, step) = step_visits(header, table, settings, source)
    y = np.full((faces, faces), np.nan)
    indicated = np.full((faces, faces), np.nan)
    for a, c, s, d, j in zip(angle, ac, run, direction, step, strict=True):
        if not (0 <= s < faces and 0 <= j < faces and d == 1) or np.isfinite(y[s, j]):
            msg = (f"{source}: setting {int(s)}, position {int(j)} (direction {int(d)}) does "
                   f"not fit a closure of {faces} faces: each of {faces} settings visits each "
                   f"of {faces} positions once")
            raise DataError(msg)
        off = math.remainder(a - j * TWO_PI / faces - angle[0], TWO_PI)  # rad
        y[s, j] = off / ARCSEC - c
        indicated[s, j] = a
    if np.isnan(y).any():
        s, j = (int(v[0]) for v in np.nonzero(np.isnan(y)))
        msg = f"{source}: setting {s} lacks position {j}: a closure needs every pair"
        raise DataError(msg)
    mean_angle = np.angle(np.exp(1j * indicated).mean(axis=0))
    return y, np.mod(mean_angle / DEG, 360.0)


def read_run(source: InputStream, settings: Settings) -> pa.Table:
    """The columns a closure reads (the measuring heads, the autocollimator, run,
    direction, step) of a readings stream, batch by batch, as one table of a few
    contiguous arrays: some (heads + 4) x 8 bytes a row, at most
    :data:`~enctools.data.limits.MAX_TABLE_ROWS` rows (DataError beyond, naming both).
    A run that claims fewer rows than its faces squared is refused before it is read."""
    import pyarrow as pa

    from enctools.data import limits
    from enctools.data.limits import MAX_TABLE_ROWS
    from enctools.methods.points import steps_inputs

    _require_closure(source.header, source.source)
    infos, autocollimator, faces = steps_inputs(source.header, settings, source.source)
    claimed = source.claimed_rows
    if claimed is not None and claimed < faces * faces:
        msg = (f"{source.source}: {claimed} rows; a closure of {faces} faces needs "
               f"{faces} settings of {faces} positions, {faces * faces} readings or more")
        raise DataError(msg)
    names = list(dict.fromkeys([*(i.name for i in infos), autocollimator,
                                *(c for c in ("run", "direction", "step")
                                  if c in source.schema.names)]))
    joined: dict[str, list[pa.Array]] = {n: [] for n in names}
    pending: dict[str, list[pa.Array]] = {n: [] for n in names}
    rows = 0
    for b in source.batches(read_ahead=0, checked=False):  # checked once, joined
        rows += b.num_rows
        if rows > MAX_TABLE_ROWS:
            msg = (f"{source.source}: over {rows} rows; a closure holds at most "
                   f"{MAX_TABLE_ROWS} rows in memory (enc-streams(5), LIMITS)")
            raise DataError(msg)
        for n in names:
            pending[n].append(b.column(n))
        if len(pending[names[0]]) >= JOIN_EVERY:
            _join(joined, pending)
    _join(joined, pending)
    schema = pa.schema([source.schema.field(n) for n in names])
    table = pa.Table.from_arrays([pa.chunked_array(joined[f.name], f.type) for f in schema],
                                schema=schema)
    limits.check_missing(table, source.source)
    checks = limits.value_checks(source.kind, schema)
    if checks:
        limits.check_batch(table, checks, source.source)
    return table


def _join(joined: dict[str, list[pa.Array]], pending: dict[str, list[pa.Array]]) -> None:
    """Move the pending small arrays of each column into one array of ``joined``."""
    import pyarrow as pa

    for n, arrays in pending.items():
        if arrays:
            joined[n].append(pa.concat_arrays(arrays))
            arrays.clear()


def closure_points(header: Header, table: pa.Table, settings: Settings, source: str
                   ) -> tuple[Header, Points, Separation]:
    """The encoder's points (one per table position, deviation relative to position 0)
    and the separation of a closure run, with the header of the points stream."""
    y, position = closure_matrix(header, table, settings, source)
    sep = separate(y)
    n = sep.faces
    points = Points(position, sep.deviation, np.ones(n, np.int8), np.zeros(n, np.int32))
    out = header.derive("points", points_schema(), source=f"closure run {source}")
    out.meta["settings"] = settings.to_meta()
    out.meta["closure"] = sep.meta()
    out.meta["figures"] = figures_meta(figures_or_nan(sep.deviation))
    return out, points, sep

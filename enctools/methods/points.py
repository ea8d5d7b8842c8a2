"""Calibration points: the error of an encoder at a few angles (polygon work, seed 001 sec. 5.3).

Two sources:

- a ``steps`` readings stream with an autocollimator looking at a polygon: at each
  position the encoder reading is the mean of the encoder's measuring heads, taken
  relative to the first position of the run; the polygon gives the true angle,
  ``j * 360/faces`` plus the autocollimator's reading relative to the first
  position (the simulator's convention: autocollimator = (theta - theta0 - j *
  2pi/faces) [arcsec] + face error). The deviation is indicated minus true angle
  [arcsec]; it is 0 at the first position.
- a user's table (text with ``#`` comments and any header, or Parquet/Arrow/HDF5
  without enctools metadata) mapped by :mod:`enctools.data.tablemap`, e.g.
  ``position_deg,deviation_arcsec[,direction,run]`` (seed 001 table 1) or a
  comparator's reference and measured angle: positions at the indicated angle.

The figures of a set of points (Bessel standard deviation, seed 001 eq. 8, and
peak-to-peak) are those of :mod:`enctools.data.statistics`, named here for the
metadata of points and models.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa

from enctools.data import limits
from enctools.data.arrays import arrow_array
from enctools.data.columns import column, declared_unit
from enctools.data.polygon import Certificate
from enctools.data.readings import head_angle, head_info, measuring_heads
from enctools.data.riglimits import RANGES
from enctools.data.schemas import column_with_role, make_field
from enctools.data.statistics import Figures, figures_or_nan
from enctools.data.tablemap import Mapping, TablePoints
from enctools.data.usertables import UserTable
from enctools.data.usertables import is_table_file as is_table_file
from enctools.errors import DataError, SettingsError
from enctools.methods import targets
from enctools.methods.polygon_run import run_meta, span_meta
from enctools.units import ARCSEC, DEG, TWO_PI, counts_factor, factor, is_length

if TYPE_CHECKING:
    from enctools.data.readings import HeadInfo
    from enctools.data.streams import Header, InputStream
    from enctools.methods.targets import TargetMeans


@dataclass
class Points:
    """Calibration points: positions [deg], deviations [arcsec], direction, run.

    The position is the indicated angle (what the encoder reads: the index of a
    correction table); ``reference_deg`` the reference angle [deg] (None: position -
    deviation). In memory angles are degrees, the argument of the error models; the
    ``points`` stream holds them in rad (:meth:`table`, :func:`from_table`).
    """

    position_deg: np.ndarray
    deviation: np.ndarray
    direction: np.ndarray
    run: np.ndarray
    reference_deg: np.ndarray | None = None
    run_meta: dict[str, Any] | None = None  # a polygon step run's figures for its budget
    #: "rotary"; or "linear" (a linear axis): positions [mm], deviations [um]
    axis: str = "rotary"

    def __len__(self) -> int:
        return int(self.position_deg.size)

    def reference(self) -> np.ndarray:
        """The reference angle of each point [deg]."""
        if self.reference_deg is not None:
            return self.reference_deg
        if self.axis == "linear":
            return self.position_deg - self.deviation * factor("um", "mm")
        return self.position_deg - self.deviation * factor("arcsec", "deg")

    def table(self) -> pa.Table:
        """The rows of a ``points`` stream: position [rad], deviation [arcsec], direction,
        run, reference [rad]; a linear axis's in mm and um."""
        schema = points_schema(self.axis)
        rad = 1.0 if self.axis == "linear" else factor("deg", "rad")
        return pa.table([arrow_array(self.position_deg * rad, pa.float64()),
                         arrow_array(self.deviation, pa.float64()),
                         arrow_array(self.direction, pa.int8()),
                         arrow_array(self.run, pa.int32()),
                         arrow_array(self.reference() * rad, pa.float64())],
                        schema=schema)


def points_schema(axis: str = "rotary") -> pa.Schema:
    """The points stream's columns: angles in rad and arcsec, a linear axis's
    (``axis`` linear) lengths in mm and um (points v4)."""
    position, deviation = ("mm", "um") if axis == "linear" else ("rad", "arcsec")
    return pa.schema([make_field("position", pa.float64(), position),
                      make_field("deviation", pa.float64(), deviation),
                      make_field("direction", pa.int8(), ""),
                      make_field("run", pa.int32(), ""),
                      make_field("reference", pa.float64(), position)])


@dataclass(frozen=True)
class Settings:
    """How enc points turns a polygon step run into points; None: from the stream.

    heads : heads averaged into the encoder reading (None: the rig's ``measure_heads``
        of the first head's encoder, else every head of it).
    autocollimator : the autocollimator column (None: the only one).
    faces : faces of the polygon (None: the rig's ``polygon.faces``).
    certificate : the polygon's certificate, a file (None: the faces taken as perfect).
    certificate_unit : the unit of its values when it states none (None: arcsec).
    first_face : the certificate's face at the run's first position (None: its first).
    """

    heads: tuple[str, ...] | None = None
    autocollimator: str | None = None
    faces: int | None = None
    certificate: str | None = None
    certificate_unit: str | None = None
    first_face: int | None = None

    def __post_init__(self) -> None:
        if self.faces is not None and self.faces < 1:
            msg = f"`faces` must be > 0, not {self.faces}"
            raise SettingsError(msg)
        most = int(RANGES["polygon.faces"][1])
        if self.faces is not None and self.faces > most:
            msg = f"`faces` must be at most {most} (a rig's polygon.faces), not {self.faces}"
            raise SettingsError(msg)
        if self.certificate is None and (self.first_face, self.certificate_unit) != (None, None):
            msg = "`first_face` and `certificate_unit` need `certificate`"
            raise SettingsError(msg)
        if self.first_face is not None and not 0 <= self.first_face <= most:
            msg = f"`first_face` must be 0..{most}, not {self.first_face}"
            raise SettingsError(msg)

    def given(self) -> list[str]:
        """The fields given, each between backticks (as an error names them)."""
        given = (("heads", self.heads), ("autocollimator", self.autocollimator),
                 ("faces", self.faces), ("certificate", self.certificate),
                 ("first_face", self.first_face))
        return [f"`{o}`" for o, v in given if v is not None]

    def check_table(self, path: str) -> None:
        """Refuse (SettingsError) the step run's fields for a table."""
        if self.given():
            msg = f"{', '.join(self.given())}: for a steps run; {path} is a table (CSV, ...)"
            raise SettingsError(msg)

    def to_meta(self) -> dict[str, Any]:
        """The ``settings`` metadata of the points stream (the options as given)."""
        out = {"heads": None if self.heads is None else list(self.heads),
               "autocollimator": self.autocollimator, "faces": self.faces}
        if self.certificate is not None:
            out |= {"polygon_certificate": self.certificate, "first_face": self.first_face}
        return out


def figures_meta(f: Figures) -> dict[str, float]:
    """The figures of points [arcsec] as the metadata of points and models name them."""
    return {"n": f.n, "mean_arcsec": f.mean, "bessel_std_arcsec": f.std,
            "peak_to_peak_arcsec": f.pp, "plus_minus_arcsec": f.plus_minus,
            "max_abs_arcsec": f.max_abs}


# ------------------------------------------------------------------ from a steps run


def points_from_steps(header: Header, table: pa.Table, settings: Settings,
                      source: str = "input", certificate: Certificate | None = None) -> Points:
    """Calibration points from a steps-mode readings stream with an autocollimator.

    Parameters
    ----------
    header, table : the readings stream (columns ``step``, ``run``, ``direction``,
        head columns [count], an autocollimator column [arcsec]).
    settings : the heads, autocollimator column and polygon faces (None: from the
        stream's rig and columns), the face at the first position.
    certificate : the polygon's face angle errors, applied to the true angle (None: the
        faces taken as perfect).

    Returns
    -------
    One point per (run, direction, step): position = mean encoder reading [deg,
    0..360), deviation = indicated - true angle relative to the run's first
    position [arcsec]; the true angle of face j is j * 360/faces plus its error from the
    certificate, relative to the first position's face.
    """
    faces, heads, ac, keys, lsb = _step_columns(header, table, settings, source)
    va, vac, vr, vd, _ = visits(heads.mean(axis=0), ac, *keys, source)
    if certificate is not None and header.meta.get("mode") == "closure":
        msg = (f"{source}: a closure run, the polygon turned between its runs: "
               "enc closure separates its face errors (`certificate` is for step runs)")
        raise DataError(msg)
    if certificate is not None and certificate.faces != faces:
        msg = (f"{certificate.source}: the certificate lists {certificate.faces} faces; the "
               f"polygon of {source} has {faces}")
        raise DataError(msg)
    dev, j = _polygon_deviation(va, vac, vr, faces, source)
    if certificate is not None:
        dev -= face_correction(certificate, j, settings.first_face)
    points = Points(np.mod(va / DEG, 360.0), dev, vd, vr)
    points.run_meta = run_meta(heads, ac, keys, (vac, vr), lsb)
    points.run_meta |= span_meta(table, keys, vr, vd)
    if np.unique(vr).size == 1 and np.unique(vd).size == 1:
        # one approach: what the budget's model of each point needs (methods/polygon_gum)
        points.run_meta |= {"ac_arcsec": [float(a) for a in vac - vac[0]],
                            "face": [int(f) for f in j]}
        if dev.size > faces and j[-1] == 0:   # a closing reading on the first face again
            points.run_meta["closing_arcsec"] = float(dev[-1] - dev[0])
    return points


def step_visits(header: Header, table: pa.Table, settings: Settings, source: str
                ) -> tuple[int, tuple[np.ndarray, ...]]:
    """The polygon's faces and the :func:`visits` of a step run (mean of the heads [rad],
    autocollimator [arcsec], run, direction, step of each)."""
    faces, heads, ac, keys, _ = _step_columns(header, table, settings, source)
    return faces, visits(heads.mean(axis=0), ac, *keys, source)


def _step_columns(header: Header, table: pa.Table, settings: Settings, source: str
                  ) -> tuple[int, np.ndarray, np.ndarray,
                             tuple[np.ndarray, np.ndarray, np.ndarray], float]:
    """The polygon's faces, each measuring head's angle [rad] (one row a head), the
    autocollimator [arcsec], the (run, direction, step) keys and one count [arcsec]."""
    for col in ("step", "run", "direction"):
        if col not in table.column_names:
            msg = (f"{source}: no {col!r} column: is this a steps-mode run "
                   "(enc acquire in steps mode)?")
            raise DataError(msg)
    if table.num_rows == 0:
        msg = f"{source}: the readings stream has no rows"
        raise DataError(msg)
    infos, autocollimator, faces = steps_inputs(header, settings, source)
    heads = np.array([head_angle(table.column(i.name), i) for i in infos])  # rad
    ac = table.column(autocollimator).to_numpy(zero_copy_only=False).astype(np.float64)
    run, direction, step = (table.column(c).to_numpy(zero_copy_only=False)
                            for c in ("run", "direction", "step"))
    return faces, heads, ac, (run, direction, step), counts_factor(
        min(i.counts_per_rev for i in infos), "arcsec")


def face_correction(cert: Certificate, j: np.ndarray, first_face: int | None) -> np.ndarray:
    """The certificate's face angle errors [arcsec] at faces ``j`` (counted from the run's
    first position) relative to the first position's face: what the true angle gains,
    so what the deviation loses. ``first_face``: the certificate's number of the face at
    the first position (None: its first face)."""
    start = 0 if first_face is None else first_face - cert.first
    if not 0 <= start < cert.faces:
        msg = (f"`first_face` {first_face}: the certificate numbers its {cert.faces} faces "
               f"{cert.first}..{cert.first + cert.faces - 1}")
        raise SettingsError(msg)
    err = cert.error_arcsec
    return err[(start + j) % cert.faces] - err[start]


def steps_inputs(header: Header, settings: Settings, source: str
                  ) -> tuple[list[HeadInfo], str, int]:
    """The heads, the autocollimator column and the polygon's faces of a step run:
    as given in ``settings``, else from the stream's rig and columns."""
    heads = (measuring_heads(header.schema, header.meta, source) if settings.heads is None
             else settings.heads)
    infos = [head_info(header.schema, h, source) for h in heads]
    autocollimator = column_with_role(header.schema, "autocollimator", settings.autocollimator,
                                      source, "`autocollimator`")
    faces = settings.faces
    if faces is None:
        faces = _rig_faces(header.meta, source)
    return infos, autocollimator, faces


def _rig_faces(meta: dict[str, Any], source: str) -> int:
    """The polygon's faces named by a stream's rig, within a rig file's range."""
    polygon = (meta.get("rig") or {}).get("polygon") or {}
    faces = polygon.get("faces") if isinstance(polygon, dict) else None
    if faces is None:
        msg = f"{source}: the rig names no polygon; give `faces`"
        raise DataError(msg)
    lo, hi = RANGES["polygon.faces"]
    if isinstance(faces, float) and faces.is_integer():
        faces = int(faces)
    if isinstance(faces, bool) or not isinstance(faces, int) or not lo <= faces <= hi:
        msg = (f"{source}: the rig's polygon.faces must be a whole number {int(lo)}..{int(hi)}, "
               f"not {faces!r}; give `faces`")
        raise DataError(msg)
    return faces


def visits(angle: np.ndarray, ac: np.ndarray, run: np.ndarray, direction: np.ndarray,
            step: np.ndarray, source: str) -> tuple[np.ndarray, ...]:
    """One row per visit of a position: consecutive rows of one (run, direction, step).

    Returns the mean encoder angle [rad] and autocollimator reading [arcsec] of each
    visit (rows without an autocollimator reading left out), its run, direction and step.
    """
    key = np.stack([run, direction, step]).T
    starts = np.flatnonzero(np.r_[True, np.any(key[1:] != key[:-1], axis=1)])
    bounds = np.r_[starts, key.shape[0]]
    vis_angle, vis_ac = [], []
    for a, b in itertools.pairwise(bounds):
        ok = np.isfinite(ac[a:b])
        if not ok.any():
            msg = (f"{source}: no autocollimator reading at step {int(step[a])} of run "
                   f"{int(run[a])} (off the face: is the polygon aligned?)")
            raise DataError(msg)
        vis_angle.append(np.mean(angle[a:b][ok]))
        vis_ac.append(np.mean(ac[a:b][ok]))
    return (np.array(vis_angle), np.array(vis_ac), run[starts].astype(np.int32),
            direction[starts].astype(np.int8), step[starts].astype(np.int64))


def _polygon_deviation(angle: np.ndarray, ac: np.ndarray, run: np.ndarray, faces: int,
                       source: str) -> tuple[np.ndarray, np.ndarray]:
    """Indicated - true angle [arcsec] of each visit, relative to its run's first one, and
    the face j of each visit counted from the first (0..faces-1).

    The true angle is ``j * 360/faces`` (j the nearest face) plus the autocollimator's
    reading [arcsec] relative to the run's first position.
    """
    pitch = TWO_PI / faces
    dev = np.empty(angle.size)
    face = np.empty(angle.size, np.int64)
    for r in np.unique(run):
        sel = np.flatnonzero(run == r)
        first = sel[0]
        rel = angle[sel] - angle[first]
        j = np.round(rel / pitch)
        true_rel = j * pitch + (ac[sel] - ac[first]) * ARCSEC
        dev[sel] = (rel - true_rel) / ARCSEC
        face[sel] = np.mod(j, faces)
        off = np.abs(rel - j * pitch) / ARCSEC
        if off.max() > 1000.0:
            msg = (f"{source}: run {int(r)}: a position is {off.max():.0f} arcsec off the "
                   f"nearest of {faces} polygon faces; wrong `faces`?")
            raise DataError(msg)
    return dev, face


# --------------------------------------------------------------------- from a table


def points_from_table(table: UserTable, mapping: Mapping | None = None
                      ) -> tuple[Points, TablePoints]:
    """Points from a user's table (text with ``#`` comments and any header, e.g.
    ``position_deg,deviation_arcsec[,direction,run]`` as seed 001's table 1 or a
    comparator's ``Reference Angle [degree],Measured Angle [degree]``; or Parquet/Arrow/
    HDF5 without enctools metadata), as read by :func:`enctools.data.usertables.read`,
    mapped by ``mapping`` (:mod:`enctools.data.tablemap`): positions at the indicated
    angle [deg], the reference angle beside them, deviations [arcsec]."""
    from enctools.data.tablemap import map_table

    tp = map_table(table.raw, mapping or Mapping())
    return Points(tp.position_deg, tp.deviation, tp.direction, tp.run, tp.reference_deg,
                  axis=tp.axis), tp


def check_points(points: Points, source: str) -> Points:
    """The points, once finite and within :mod:`~enctools.data.limits`' ranges: positions
    within +-MAX_ABS_DEG deg, deviations within +-MAX_ABS_ARCSEC arcsec (a linear axis's
    both within +-MAX_ABS_LENGTH_M), directions +-1."""
    bounds = ((("position", limits.MAX_ABS_LENGTH_M * 1e3, "mm"),
               ("deviation", limits.MAX_ABS_LENGTH_M * 1e6, "um")) if points.axis == "linear"
              else (("position", limits.MAX_ABS_DEG, "deg"),
                    ("deviation", limits.MAX_ABS_ARCSEC, "arcsec")))
    for (what, bound, unit), values in zip(bounds, (points.position_deg, points.deviation),
                                           strict=True):
        bad = ~(np.abs(values) <= bound)
        if bad.any():
            msg = (f"{source}: {what} {values[bad][0]} {unit} is not finite within "
                   f"+-{bound:g} {unit} (enc-streams(5), LIMITS)")
            raise DataError(msg)
    return points


def from_table(table: pa.Table, source: str = "input", meta: dict[str, Any] | None = None,
               linear: bool = False) -> Points:
    """Points from the rows of a ``points`` stream: position in the unit of its field
    metadata (rad; deg in a v1 stream), deviation [arcsec]. ``meta``: the stream's
    metadata, whose schema version says the unit of a column that names none.
    ``linear``: a linear axis's (mm, um) are taken, else refused (:func:`rotary`)."""
    n = table.num_rows
    if n == 0:
        msg = f"{source}: the points stream has no rows"
        raise DataError(msg)
    angle, error = ("mm", "um") if is_linear(table.schema) else ("deg", "arcsec")
    pos = column(table, "position", angle, source,
                 declared_unit("points", meta or {}, "position"))
    dev = column(table, "deviation", error, source)
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(dev))):
        msg = f"{source}: position or deviation holds NaN or infinite values"
        raise DataError(msg)
    names = table.column_names
    d = table.column("direction").to_numpy(zero_copy_only=False) if "direction" in names \
        else np.ones(n)
    r = table.column("run").to_numpy(zero_copy_only=False) if "run" in names else np.zeros(n)
    ref = column(table, "reference", angle, source) if "reference" in names else None
    if ref is not None and not np.all(np.isfinite(ref)):
        msg = f"{source}: reference holds NaN or infinite values"
        raise DataError(msg)
    points = Points(pos, dev, np.asarray(d, np.int8), np.asarray(r, np.int32), ref,
                    axis="linear" if is_linear(table.schema) else "rotary")
    return points if linear else rotary(points, source)


def rotary(points: Points, source: str) -> Points:
    """The points, when a rotary axis's: a linear axis's (mm, um) are refused with one
    DataError line (the error models and correction tables are of angles over a turn)."""
    if points.axis == "linear":
        msg = (f"{source}: a linear axis's points (mm, um): this command takes a rotary "
               "axis's angles; enc report gives a linear axis's ISO 230-2 figures")
        raise DataError(msg)
    return points


def is_linear(schema: pa.Schema) -> bool:
    """Whether a points stream is a linear axis's: its position in a length (field
    metadata ``unit`` mm, points v4)."""
    from enctools.data.columns import column_unit

    return "position" in schema.names and is_length(column_unit(schema, "position"))


def _table_header(path: str, mapping: Mapping, tp: TablePoints) -> Header:
    """The header of points from a user's table: its source, mapping and zero offset."""
    from enctools.data import streams

    meta = {"source": f"table {path}", "history": [], "table": tp.meta() | {
        "mapping": mapping.to_meta()}, "zero_offset_arcsec": tp.zero_offset_arcsec,
        "zero_offset_removed": tp.offset_removed}
    if tp.axis == "linear":
        meta = {k: v for k, v in meta.items() if k != "zero_offset_arcsec"}
        meta |= {"axis": "linear", "zero_offset_um": tp.zero_offset_arcsec}
    return streams.Header("points", points_schema(tp.axis), meta)


def read_points(src: UserTable | InputStream, mapping: Mapping | None = None,
                linear: bool = False) -> tuple[Header, Points]:
    """Points from a user's table mapped by ``mapping`` (:func:`points_from_table`) or a
    points stream (a mapping's fields are then refused), as opened by
    :func:`enctools.data.usertables.open_input`; a linear axis's only with ``linear``
    (else refused, :func:`rotary`)."""
    mapping = mapping or Mapping()
    if isinstance(src, UserTable):
        points, tp = points_from_table(src, mapping)
        points = points if linear else rotary(points, src.source)
        return _table_header(src.source, mapping, tp), check_points(points, src.source)
    _no_mapping(mapping, src.source)
    return src.header, check_points(from_table(src.read_all(), src.source, src.header.meta,
                                               linear), src.source)


def open_points(path: str | None, expect: tuple[str, ...], mapping: Mapping | None = None
                ) -> InputStream:
    """The stream of a kind in ``expect`` at ``path`` (None, "-": stdin), or a user's
    table read as a points stream (its columns mapped by ``mapping``, :func:`read_points`)
    when ``path`` is one: what a command that takes a points stream or a table opens. A
    table given where no points are taken is refused naming the kinds taken; a mapping's
    fields given for a stream are refused."""
    from enctools.data import streams, usertables

    mapping = mapping or Mapping()
    if path is None or not usertables.is_table_file(path):
        src = streams.open_input(path, expect)
        if mapping.given():
            src.close()
            _no_mapping(mapping, src.source)
        return src
    if "points" not in expect:
        from enctools.data.csvio import sidecar_path
        from enctools.data.streams import detect_format

        with open(path, "rb") as f:
            text = detect_format(f.read(8)) is None
        stream = (f" (its sidecar {sidecar_path(path)}, which is missing, would make it a "
                  "stream)") if text else ""
        msg = (f"{path} is a table{stream}: a table gives points, and here a "
               f"{' or '.join(expect)} stream is read (fit a model to the points first)")
        raise DataError(msg)
    header, points = read_points(usertables.read(path, bool(mapping.decimal_comma)), mapping)
    return streams.InputStream(header, iter(points.table().to_batches()), path, "table")


def _no_mapping(mapping: Mapping, source: str | None) -> None:
    """Refuse (SettingsError) a table's column fields for a stream."""
    if mapping.given():
        msg = f"{', '.join(mapping.given())}: for a table; {source or 'stdin'} is a stream"
        raise SettingsError(msg)


def make_points(src: UserTable | InputStream, settings: Settings,
                mapping: Mapping | None = None, certificate: Certificate | None = None
                ) -> tuple[Header, Points]:
    """The points of enc points and the header of their stream.

    ``src``: a user's table or a steps-mode readings stream as opened by
    :func:`enctools.data.usertables.open_input`; ``certificate``: the polygon's
    certificate ``settings.certificate`` names, as read by
    :func:`enctools.data.polygon.read_certificate` (None: no certificate). From a
    table (:func:`read_points`; the step run's settings are refused) or a stream
    (:func:`points_from_steps`; the table's column fields are refused). The header
    carries the settings, the targets the points visit (:func:`target_means`:
    ``targets``) and the figures of their mean deviations [arcsec] (``figures``).
    """
    mapping = mapping or Mapping()
    if isinstance(src, UserTable):
        settings.check_table(src.source)
        header, points = read_points(src, mapping, linear=True)
    else:
        _no_mapping(mapping, src.source)
        cert = certificate
        points = check_points(points_from_steps(src.header, src.read_all(), settings, src.source,
                                                cert), src.source)
        header = src.header.derive("points", points_schema(), source=f"steps run {src.source}")
        if cert is not None:
            header.meta["polygon_certificate"] = cert.meta() | {
                "first_face": cert.first if settings.first_face is None else settings.first_face}
        header.meta["polygon_run"] = points.run_meta
    header.meta["settings"] = settings.to_meta()
    if points.axis == "linear":     # targets over a turn and their figures: of angles
        return header, points
    means = target_means(points, header.meta.get("source", "input"), header.meta)
    header.meta["figures"] = figures_meta(figures_or_nan(means.mean))
    header.meta["targets"] = means.targets.meta()
    return header, points


def count_deg(meta: dict[str, Any] | None) -> float:
    """One count [deg] of the coarsest encoder of the rig a stream names (0: none named):
    the least tolerance of :func:`enctools.methods.targets.tolerance`."""
    from enctools.data.readings import rig_encoders

    counts = [e.counts_per_rev for e in rig_encoders(meta or {}) if e.counts_per_rev > 0]
    return 360.0 / min(counts) if counts else 0.0


def target_means(points: Points, source: str = "input", meta: dict[str, Any] | None = None
                 ) -> TargetMeans:
    """The points grouped into targets and their deviation per target and direction
    [arcsec] (:func:`enctools.methods.targets.target_means`; ``meta``: the stream's
    metadata, whose rig gives one count of the encoder)."""
    return targets.target_means(points.position_deg, points.deviation, points.direction,
                                points.run, count_deg(meta), source)


def distinct(points: Points, source: str = "input", meta: dict[str, Any] | None = None
             ) -> tuple[np.ndarray, np.ndarray, float]:
    """The targets [deg, 0..360) and the mean deviation at each [arcsec] over runs and
    directions (:func:`target_means`), and the largest spread of one target's visits
    [arcsec] (the closure error of a 0/360 pair, the repeatability of a step run)."""
    t = target_means(points, source, meta)
    return t.position_deg, t.mean, t.spread

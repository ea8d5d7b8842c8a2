"""Curves and spectra as enctools tables: the deviations and spectrum stream kinds.

The methods return numpy arrays; this module lays them out as Arrow tables with the
field metadata the kinds ask for (unit, role, ``of`` for uncertainties).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.arrays import arrow_array
from enctools.data.columns import uncertainty_name
from enctools.data.schemas import make_field


@dataclass
class Column:
    """One curve of a deviations table: values on the grid, its role and unit."""

    name: str
    values: np.ndarray
    role: str = "deviation"           # deviation [arcsec] | radial [nm] | uncertainty [arcsec]
    unit: str = "arcsec"
    meta: dict[str, Any] = field(default_factory=dict)


def uncertainty(of: str, values: np.ndarray, unit: str = "arcsec",
                coverage: dict[str, str] | None = None) -> Column:
    """The standard uncertainty of curve ``of`` [its unit: arcsec or nm] as the naming rule
    has it: column ``u_<of>``, role ``uncertainty``, field metadata ``of``; ``coverage``:
    the field metadata ``dof``, ``k`` and ``coverage`` of its expanded uncertainty."""
    return Column(uncertainty_name(of), values, "uncertainty", unit,
                  {"of": of} | (coverage or {}))


def deviations_table(theta: np.ndarray, columns: list[Column]) -> pa.Table:
    """A deviations table: ``theta`` [rad] then one column per curve."""
    fields = [make_field("theta", pa.float64(), "rad")]
    arrays = [arrow_array(theta, pa.float64())]
    for c in columns:
        fields.append(make_field(c.name, pa.float64(), c.unit, c.role, **c.meta))
        arrays.append(arrow_array(c.values, pa.float64()))
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields))


def spectrum_table(curves: list[tuple[str, np.ndarray, np.ndarray | None, np.ndarray | None]],
                   first: int = 1, coverage: dict[str, str] | None = None) -> pa.Table:
    """A spectrum table: one row per curve and harmonic n = first..K.

    ``curves``: (name, coefficients c_0..c_K [arcsec], transfer |W(n)| or None,
    standard uncertainty u [arcsec] or None). amplitude = |c_n|, phase = arg c_n
    (``amplitude * cos(n x + phase)``), re = a, im = -b, ``u_amplitude`` = u, with
    ``coverage`` (field metadata ``dof``, ``k``, ``coverage``) when its U is stated.
    """
    u_name = uncertainty_name("amplitude")
    rows: dict[str, list[Any]] = {k: [] for k in ("n", "amplitude", "phase", "re", "im",
                                                  "transfer", u_name, "curve")}
    for name, c, transfer, u in curves:
        n = np.arange(first, c.size)
        cc = c[first:]
        rows["n"] += n.tolist()
        rows["amplitude"] += np.abs(cc).tolist()
        rows["phase"] += np.angle(cc).tolist()
        rows["re"] += cc.real.tolist()
        rows["im"] += cc.imag.tolist()
        none = np.full(n.size, np.nan)
        rows["transfer"] += (none if transfer is None else transfer[first:]).tolist()
        rows[u_name] += (none if u is None else u[first:]).tolist()
        rows["curve"] += [name] * n.size
    fields = [make_field("n", pa.int64(), ""), make_field("amplitude", pa.float64(), "arcsec"),
              make_field("phase", pa.float64(), "rad"), make_field("re", pa.float64(), "arcsec"),
              make_field("im", pa.float64(), "arcsec"), make_field("transfer", pa.float64(), ""),
              make_field(u_name, pa.float64(), "arcsec", "uncertainty", of="amplitude",
                         **(coverage or {})),
              make_field("curve", pa.string(), "")]
    return pa.Table.from_pydict(rows, schema=pa.schema(fields))

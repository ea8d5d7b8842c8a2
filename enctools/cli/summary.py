"""One way every command hands out its summary: text on stderr, or JSON on stdout.

A command builds its summary as a plain dict in the vocabulary of
:mod:`enctools.data.summaries` (enc-streams(5), SUMMARIES) and calls :func:`emit`:

- without ``--json``: one line per group on stderr, ``enc CMD: group: label value, ...``,
  the angles (keys ending ``_arcsec``) in the ``--unit`` chosen; nothing with ``-q``;
- with ``--json``: the dict as one JSON document on stdout (``-q`` does not silence
  it: it is the output asked for). A command whose stream would go to stdout needs
  ``-o FILE`` for ``--json`` (:func:`check_json`), checked before any work.
"""

from __future__ import annotations

import math
import sys
from typing import Any

from enctools.cli import runner

#: how a key's stem reads in text (the stem is the key without its unit suffix)
LABELS = {"pp": "p-p", "pm": "+/-", "s_bessel": "Bessel s", "n_points": "n", "lsb": "LSB",
          "max_abs": "max |e|", "u_max": "u max", "expanded_u_max": "U max",
          "coverage_k": "k", "dof": "nu"}
#: unit suffixes of keys other than angles, printed after the value as they are
SUFFIXES = ("nm", "deg_s", "rpm", "rev_s", "s", "deg", "rad", "lsb", "bytes", "m", "counts",
            "percent")
SHOWN = {"lsb": "LSB", "percent": "%"}
#: at most this many items of a list (of groups) are printed in text (JSON has them all)
TEXT_ITEMS = 4
TEXT_GROUPS = 2
#: keys left out of the text (JSON has them)
TEXT_OMIT = frozenset({"role", "phase_rad", "u_amplitude_arcsec", "u_amplitude_nm"})


def check_json(as_json: bool, output: str | None, what: str = "-o FILE") -> None:
    """UsageError when ``--json`` would share stdout with the command's stream."""
    from enctools.cli.usage import UsageError

    if as_json and (output is None or output == "-"):
        msg = f"--json prints the summary on stdout, where the stream goes: give {what}"
        raise UsageError(msg)
    if as_json and sys.stdout is None:  # checked before the work, not after its outputs
        raise UsageError("stdout is closed: --json has nowhere to print the summary")


def emit(summary: dict[str, Any], as_json: bool = False, unit: str = "arcsec") -> None:
    """Print ``summary``: JSON on stdout with ``as_json``, else text lines on stderr
    (angles in ``unit``) unless the command was given -q."""
    if as_json:
        from enctools.data.summaries import to_json
        from enctools.errors import OutputError

        if sys.stdout is None:
            raise OutputError("stdout is closed: the --json summary cannot be printed")
        sys.stdout.write(to_json(summary) + "\n")
        sys.stdout.flush()
        return
    if runner.is_quiet():
        return
    runner.end_progress()
    name = runner.command_name()
    try:
        for line in text_lines(summary, unit):
            sys.stderr.write(f"{name}: {line}\n")
        sys.stderr.flush()
    except OSError:  # stderr full (2>/dev/full): the summary is lost, not the work
        pass


def text_lines(summary: dict[str, Any], unit: str = "arcsec") -> list[str]:
    """The summary as lines of text: its plain values on the first line, then one line
    per group (a dict) and per named item of a list of dicts."""
    from enctools.data.text import printable

    lines: list[str] = []
    plain: list[str] = []  # consecutive plain values: one line, in their place

    def flush() -> None:
        if any(plain):
            lines.append(", ".join(p for p in plain if p))
        plain.clear()

    for key, value in summary.items():
        if isinstance(value, dict):
            flush()
            lines.append(f"{key.replace('_', ' ')}: {_items(value, unit)}")
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            flush()
            for v in value:
                name = v.get("name", key)
                lines.append(f"{name}: {_items({k: x for k, x in v.items() if k != 'name'}, unit)}")
        else:
            plain.append(_item(key, value, unit))
    flush()
    return [printable(ln) for ln in lines]


def _items(d: dict[str, Any], unit: str) -> str:
    if "n" in d and any(k.startswith("amplitude_") for k in d):  # a harmonic: n=3: 0.12"
        key = next(k for k in d if k.startswith("amplitude_"))
        return f"n={d['n']}: {_value(key, d[key], unit)}"
    return ", ".join(t for t in (_item(k, v, unit) for k, v in d.items()
                                 if k not in TEXT_OMIT) if t)


def _item(key: str, value: Any, unit: str) -> str:
    """``label value[unit]`` of one key; lists shortened, nested groups in brackets."""
    if isinstance(value, dict):
        return f"{key.replace('_', ' ')} ({_items(value, unit)})"
    if isinstance(value, list):
        if not value:
            return ""
        stem, suffix = split_unit(key)
        if isinstance(value[0], dict):
            shown = [_items(v, unit) for v in value[:TEXT_GROUPS]]
            more = f" (+{len(value) - TEXT_GROUPS})" if len(value) > TEXT_GROUPS else ""
            return f"{key.replace('_', ' ')} {'; '.join(shown)}{more}"
        plain = suffix not in ("", "arcsec")  # the unit once, after the list
        shown = [_value("" if plain else key, v, unit) for v in value[:TEXT_ITEMS]]
        more = f" (+{len(value) - TEXT_ITEMS})" if len(value) > TEXT_ITEMS else ""
        after = f" {SHOWN.get(suffix, suffix.replace('_', '/'))}" if plain else ""
        return f"{stem.replace('_', ' ')} {','.join(shown)}{more}{after}"
    stem, _ = split_unit(key)
    label = LABELS.get(key, LABELS.get(stem, stem[2:] if stem.startswith("n_") else stem))
    return f"{label.replace('_', ' ')} {_value(key, value, unit)}"


def split_unit(key: str) -> tuple[str, str]:
    """A key's stem and its unit suffix (``pp_arcsec`` -> ``pp``, ``arcsec``; no unit: "")."""
    if key.endswith("_arcsec"):
        return key[: -len("_arcsec")], "arcsec"
    for s in SUFFIXES:
        if key.endswith(f"_{s}"):
            return key[: -len(s) - 1], s
    return key, ""


def _value(key: str, value: Any, unit: str) -> str:
    from enctools.units import factor, symbol

    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if not isinstance(value, (int, float)):
        return str(value)
    if isinstance(value, float) and not math.isfinite(value):
        return "n/a"
    _, suffix = split_unit(key)
    if suffix == "arcsec":
        sym = symbol(unit)
        v = value * factor("arcsec", unit)
        return f"{v:.5g}{sym}" if sym in ('"', "°") else f"{v:.5g} {sym}"
    text = f"{value:.5g}" if isinstance(value, float) else str(value)
    return f"{text} {SHOWN.get(suffix, suffix.replace('_', '/'))}" if suffix else text


def curves(header: Any, table: Any) -> list[dict[str, Any]]:
    """The figures of each deviation and radial-motion column of a deviations stream, in
    its unit (arcsec, nm), with the largest standard uncertainty of its ``u`` column and,
    when that column states its coverage (field metadata ``k``, ``dof``), k, the degrees
    of freedom and the largest expanded uncertainty U = k u."""
    import numpy as np

    from enctools.data.columns import uncertainty_columns
    from enctools.data.schemas import field_meta
    from enctools.data.statistics import curve_figures
    from enctools.data.summaries import figure_dict

    metas = {f.name: field_meta(f) for f in header.schema}
    u_of = uncertainty_columns(header.schema)
    out = []
    for name, m in metas.items():
        if m.get("role") not in ("deviation", "radial"):
            continue
        unit = m.get("unit", "arcsec")
        values = table.column(name).to_numpy(zero_copy_only=False)
        d: dict[str, Any] = {"name": name, "role": m["role"]}
        d |= figure_dict(curve_figures(values), unit, ("pp", "pm", "s_bessel", "rms"))
        if name in u_of:
            u = table.column(u_of[name]).to_numpy(zero_copy_only=False)
            d[f"u_max_{unit}"] = float(np.max(u)) if u.size else None
            d |= _expanded(metas[u_of[name]], d[f"u_max_{unit}"], unit)
        out.append(d)
    return out


def _expanded(u_meta: dict[str, str], u_max: float | None, unit: str) -> dict[str, Any]:
    """k, the degrees of freedom and U max of an uncertainty column that states its
    coverage in its field metadata (``k``, ``dof``; checked when the stream was read)."""
    if "k" not in u_meta:
        return {}
    k = float(u_meta["k"])
    dof = float(u_meta.get("dof", "inf"))
    return {"coverage_k": k, "dof": dof if math.isfinite(dof) else None,
            f"expanded_u_max_{unit}": None if u_max is None else k * u_max}

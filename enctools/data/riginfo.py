"""What a person reads of a rig: the bundled rigs, a rig file's text, its summary.

``enc rig`` prints these; the rig itself is read and checked by :mod:`enctools.data.rig`.
"""

from __future__ import annotations

import math
from typing import Any

from enctools.data.rig import Rig, bundled_rigs, load_rig, rig_text
from enctools.data.text import printable


def listing() -> list[tuple[str, str]]:
    """(name, description) of every rig shipped with enctools."""
    return [(name, load_rig(name).description) for name in bundled_rigs()]


def text(name_or_path: str) -> str:
    """A rig file's TOML text, comments included, once it loads as a rig (DataError if not)."""
    load_rig(name_or_path)
    return rig_text(name_or_path)[0]


def summary(rig: Rig) -> list[str]:
    """Lines describing a rig: its backend, encoders and heads (angles [deg], counts per
    revolution [count], resolution [arcsec]), probes, polygon and acquisition defaults."""
    out = [f"rig: {printable(rig.name)}", f"  file: {printable(rig.source)}"]
    if rig.description:
        out.append(f"  {printable(rig.description)}")
    out.append(f"  backend: {printable(str(rig.backend.get('kind', 'sim')))}")
    for e in rig.encoders:
        lsb = 1_296_000.0 / e.counts_per_rev
        out.append(f"  encoder {printable(e.name)}: {e.periods_per_rev} periods x "
                   f"{e.interpolation} = {e.counts_per_rev} counts/rev ({lsb:.4g}\"), "
                   f"diameter {e.diameter_mm:g} mm, {e.counter_bits}-bit counter")
        heads = ", ".join(f"{printable(h.name)} {math.degrees(h.angle):g}" for h in e.heads)
        out.append(f"    heads [deg]: {heads}")
    for p in rig.probes:
        out.append(f"  probe {printable(p.name)}: arm {p.arm_mm:g} mm, side {p.side:+d}")
    if rig.polygon:
        out.append(f"  polygon: {rig.polygon.get('faces')} faces")
    mode = rig.acquire.get("mode", "continuous")
    out.append(f"  acquire: {printable(str(mode))} by default")
    return out


def summary_dict(rig: Rig) -> dict[str, Any]:
    """What :func:`summary` says, as a dict for ``enc rig check --json``
    (enc-streams(5), SUMMARIES): head angles [deg], resolution [arcsec], sizes [mm]."""
    return {
        "name": rig.name, "source": rig.source, "description": rig.description,
        "backend": str(rig.backend.get("kind", "sim")),
        "encoders": [{"name": e.name, "periods_per_rev": e.periods_per_rev,
                      "interpolation": e.interpolation, "counts_per_rev": e.counts_per_rev,
                      "lsb_arcsec": 1_296_000.0 / e.counts_per_rev,
                      "diameter_mm": e.diameter_mm, "counter_bits": e.counter_bits,
                      "heads": [{"name": h.name, "alpha_deg": math.degrees(h.angle)}
                                for h in e.heads]} for e in rig.encoders],
        "probes": [{"name": p.name, "arm_mm": p.arm_mm, "side": p.side} for p in rig.probes],
        "polygon_faces": rig.polygon.get("faces") if rig.polygon else None,
        "acquire_mode": str(rig.acquire.get("mode", "continuous"))}

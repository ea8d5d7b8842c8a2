"""What a person reads of a rig: the bundled rigs, a rig file's text, its summary.

``enc rig`` prints these; the rig itself is read and checked by :mod:`enctools.data.rig`.
"""

from __future__ import annotations

from typing import Any

from enctools.data.rig import Rig, bundled_rigs, load_rig, rig_text
from enctools.data.text import printable
from enctools.data.uncertainty import BASE_UNIT, declarations
from enctools.units import ARCSEC, DEG, TWO_PI, factor


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
        lsb = TWO_PI * factor("rad", "arcsec") / e.counts_per_rev
        out.append(f"  encoder {printable(e.name)}: {e.periods_per_rev} periods x "
                   f"{e.interpolation} = {e.counts_per_rev} counts/rev ({lsb:.4g}\"), "
                   f"diameter {e.diameter_mm:g} mm, {e.counter_bits}-bit counter")
        heads = ", ".join(f"{printable(h.name)} {h.angle / DEG:g}" for h in e.heads)
        out.append(f"    heads [deg]: {heads}")
    for p in rig.probes:
        out.append(f"  probe {printable(p.name)}: arm {p.arm_mm:g} mm, side {p.side:+d}")
    if rig.polygon:
        out.append(f"  polygon: {rig.polygon.get('faces')} faces")
    for d in declarations(rig.uncertainty, "uncertainty").values():
        k = f" (k={d.k:g})" if d.k != 1.0 else ""
        out.append(f"  uncertainty {d.quantity}: {d.value:g} {d.unit} {d.distribution}{k}, "
                   f"u {d.value / d.divisor:.4g} {d.unit}"
                   f"{'; ' + printable(d.source) if d.source else ''}")
    mode = rig.acquire.get("mode", "continuous")
    out.append(f"  acquire: {printable(str(mode))} by default")
    return out


def summary_dict(rig: Rig) -> dict[str, Any]:
    """What :func:`summary` says, as a dict for enc rig check's JSON
    (enc-streams(5), SUMMARIES): head angles [deg], resolution [arcsec], sizes [mm]."""
    return {
        "name": rig.name, "source": rig.source, "description": rig.description,
        "backend": str(rig.backend.get("kind", "sim")),
        "encoders": [{"name": e.name, "periods_per_rev": e.periods_per_rev,
                      "interpolation": e.interpolation, "counts_per_rev": e.counts_per_rev,
                      "lsb_arcsec": TWO_PI / e.counts_per_rev / ARCSEC,
                      "diameter_mm": e.diameter_mm, "counter_bits": e.counter_bits,
                      "heads": [{"name": h.name, "alpha_deg": h.angle / DEG}
                                for h in e.heads]} for e in rig.encoders],
        "probes": [{"name": p.name, "arm_mm": p.arm_mm, "side": p.side} for p in rig.probes],
        "polygon_faces": rig.polygon.get("faces") if rig.polygon else None,
        "uncertainty": {q: {"value": d.value, "unit": d.unit, "distribution": d.distribution,
                            "k": d.k, "standard": d.standard,
                            "standard_unit": BASE_UNIT[d.dimension], "source": d.source}
                        for q, d in declarations(rig.uncertainty, "uncertainty").items()},
        "acquire_mode": str(rig.acquire.get("mode", "continuous"))}

"""What a person reads of a rig: the bundled rigs, a rig file's text, its summary.

``enc rig`` prints these; the rig itself is read and checked by :mod:`enctools.data.rig`.
"""

from __future__ import annotations

from enctools.data.rig import Rig, bundled_rigs, load_rig, rig_text
from enctools.data.text import printable
from enctools.units import DEG, TWO_PI, factor


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
    mode = rig.acquire.get("mode", "continuous")
    out.append(f"  acquire: {printable(str(mode))} by default")
    return out

"""One line of a Monte Carlo's verdict: the coverage of a budget's U and whether it lies in
the band `make bench` requires (about 95 %), shared by the coverage scripts."""

from __future__ import annotations


def report_band(title: str, p: float, over: str, band: tuple[float, float],
                rest: str = "") -> bool:
    """Print "TITLE: coverage P over OVER (band LO..HI: ok|OUT); REST" and return whether
    the coverage ``p`` (a fraction) lies in ``band``."""
    inside = band[0] <= p <= band[1]
    print(f"{title}: coverage {p:.3f} over {over} (band {band[0]:.2f}..{band[1]:.2f}: "
          f"{'ok' if inside else 'OUT'})" + (f"; {rest}" if rest else ""))
    return inside

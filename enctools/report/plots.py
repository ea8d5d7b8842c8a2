"""The report's plots, as matplotlib Figures (object API: no pyplot state, no display).

Every plot labels both axes with units: angle [deg] (or phase within the signal
period [deg]), deviation [arcsec, or the unit the report is read in], radial
motion [nm], signals [V], harmonic order [1/rev or 1/period], time [UTC].
"""

from __future__ import annotations

import io
import os
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal, cast

import numpy as np

from enctools.report import longcurves
from enctools.report.display import in_length, label
from enctools.report.sections import Curve, Section, SpectrumRows
from enctools.units import ANGLE_UNITS, DEG, TWO_PI

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from matplotlib.projections.polar import PolarAxes

SIZE = (7.2, 3.4)
COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#17becf",
          "#7f7f7f", "#bcbd22", "#e377c2"]


#: the margins of a plot [inch]: the tick labels and axis label (left, bottom), the title
#: (top); a legend beside the axes adds its width on the right, rotated date labels and a
#: polar plot's angle labels theirs
MARGINS_IN = {"left": 0.8, "bottom": 0.5, "top": 0.32, "right": 0.15}


def matplotlib_ready() -> None:
    """Settle where matplotlib keeps its configuration and cache, before its first import.

    Where its default folders (``$XDG_CONFIG_HOME`` or ``~/.config``, ``$XDG_CACHE_HOME``
    or ``~/.cache``, each ``/matplotlib``) cannot be made or written (a read-only or
    missing HOME), MPLCONFIGDIR is set to a private temporary folder, removed at exit:
    matplotlib would otherwise warn on stderr and leave a folder of its own behind. A
    MPLCONFIGDIR the user set is kept.
    """
    if "matplotlib" in sys.modules or os.environ.get("MPLCONFIGDIR") or _defaults_writable():
        return
    import atexit
    import shutil
    import tempfile

    try:
        folder = tempfile.mkdtemp(prefix="enctools-matplotlib-")
    except OSError:  # no temporary folder either: matplotlib says so itself
        return
    os.environ["MPLCONFIGDIR"] = folder
    atexit.register(shutil.rmtree, folder, ignore_errors=True)


def _defaults_writable() -> bool:
    """Whether matplotlib's default configuration and cache folders are (or can be made)
    writable folders."""
    home = os.path.expanduser("~")
    for variable, default in (("XDG_CONFIG_HOME", ".config"), ("XDG_CACHE_HOME", ".cache")):
        base = os.environ.get(variable) or os.path.join(home, default)
        if not os.path.isabs(base):       # no HOME and no password entry: "~"
            return False
        folder = os.path.join(base, "matplotlib")
        try:
            os.makedirs(folder, exist_ok=True)
        except OSError:
            return False
        if not os.access(folder, os.W_OK):
            return False
    return True


def new_figure(size: tuple[float, float] = SIZE) -> Figure:
    """An empty figure of ``size`` [inch], matplotlib imported once its folders are
    settled (:func:`matplotlib_ready`)."""
    matplotlib_ready()
    from matplotlib.figure import Figure

    return Figure(figsize=size)


def to_png(fig: Figure, dpi: int = 110) -> bytes:
    """The figure as PNG bytes: its axes laid out within fixed margins and drawn once (a
    "tight" bounding box would draw every plot twice), on white, in 256 colours (a
    plot's few colours and their anti-aliased edges: a third of the bytes of full colour,
    and quicker to write and to embed)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    _escape_texts(fig)
    _fit_margins(fig)
    fig.set_dpi(dpi)
    for ax in fig.axes:
        _title_in_place(ax)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    rgba = canvas.buffer_rgba()
    image = Image.frombuffer("RGBA", (rgba.shape[1], rgba.shape[0]), rgba, "raw", "RGBA", 0, 1)
    indexed = image.convert("RGB").quantize(256, method=Image.Quantize.FASTOCTREE)
    # the octree averages the page's white to 254: every colour within 3 of white is white
    palette = indexed.getpalette() or []
    indexed.putpalette([255 if min(palette[i - i % 3:i - i % 3 + 3]) >= 252 else v
                        for i, v in enumerate(palette)])
    buf = io.BytesIO()
    indexed.save(buf, "png")
    return buf.getvalue()


def _escape_texts(fig: Figure) -> None:
    """Every text of the figure (titles, labels, legends: file and curve names) shown as
    the documents show text: controls, line separators, bidi and zero-width characters
    and the bytes of a name that is not UTF-8 escaped (:func:`enctools.data.text.escaped`)."""
    from matplotlib.text import Text

    from enctools.data.text import escaped

    for text in fig.findobj(Text):
        shown = escaped(text.get_text())
        if shown != text.get_text():
            text.set_text(shown)


def _legend_width_in(ax: Any) -> float:
    """The width [inch] of a legend placed beside the axes (0 when it is inside), from
    its longest label at its font size."""
    legend = ax.get_legend()
    if legend is None or legend.get_bbox_to_anchor().x0 <= ax.bbox.x1:
        return 0.0
    texts = legend.get_texts()
    chars = max((len(t.get_text()) for t in texts), default=0)
    size_pt = texts[0].get_fontsize() if texts else 7.0
    return 0.6 * size_pt / 72.0 * chars + 0.6      # glyphs, the handle and the padding


def _fit_margins(fig: Figure) -> None:
    """Margins [inch] of :data:`MARGINS_IN`, widened for what a plot has outside them."""
    wide, high = fig.get_size_inches()
    m = dict(MARGINS_IN)
    polar = any(ax.name == "polar" for ax in fig.axes)
    if polar:
        m = {"left": 0.45, "right": 0.45, "top": 0.7, "bottom": 0.75}
    if any(t.label1.get_rotation() for ax in fig.axes for t in ax.xaxis.majorTicks):
        m["bottom"] = 0.95                             # dates written at a slant
    if any(ax.get_title() and "\n" in ax.get_title() for ax in fig.axes) and not polar:
        m["top"] += 0.15
    m["right"] += max((_legend_width_in(ax) for ax in fig.axes), default=0.0)
    fig.subplots_adjust(left=m["left"] / wide, right=1 - m["right"] / wide,
                        bottom=m["bottom"] / high, top=1 - m["top"] / high)


def _title_in_place(ax: Any) -> None:
    """Put the title of axes ``ax`` at their top edge now, where matplotlib would put it
    after measuring every tick label of both axes for one that could be in its way (a
    tenth of a plot's drawing). Only a polar plot's angle labels and the offset or power
    of ten that a y axis may write above its ticks ever are; such axes keep matplotlib's
    placement."""
    if ax.name == "polar" or not ax.get_title():
        return
    formatter = ax.yaxis.get_major_formatter()
    formatter.format_ticks(ax.yaxis.get_majorticklocs())   # sets the offset, if any
    if not formatter.get_offset():
        ax.set_title(ax.get_title(), fontsize=ax.title.get_fontsize(), y=1.0)


def axes_text(fig: Figure) -> str:
    """What a figure's axes show, with their units, for its caption: "deviation
    [arcsec] against angle [deg]" (the plot is a picture; its caption is text)."""
    parts = []
    for ax in fig.axes:
        x, y = ax.get_xlabel(), ax.get_ylabel()
        if x or y:
            parts.append(f"{y} against {x}" if x and y else x or y)
    return "; ".join(parts)


def _angle_deg(c: Curve) -> np.ndarray:
    """The abscissa: angle [deg], phase within the signal period [deg], or a linear scale's
    position within it [nm] (phase / 2 pi x period)."""
    if in_length(c):
        return np.mod(np.asarray(c.angle), TWO_PI) / TWO_PI * c.extra.get("signal_period_nm",
                                                                          TWO_PI)
    return np.mod(np.asarray(c.angle), TWO_PI) / DEG if c.domain == "period" \
        else np.asarray(c.angle) / DEG


def _angle_label(c: Curve) -> str:
    if in_length(c):
        return ("position within the signal period [nm]" if "signal_period_nm" in c.extra
                else "phase within the signal period [rad]")
    return "angle [deg]" if c.domain != "period" else "phase within the signal period [deg]"


def _unit_label(unit: str, length: bool = False) -> str:
    if length:
        return f"interpolation error [{unit}]"
    if unit in ANGLE_UNITS:
        return f"deviation [{label(unit)}]"
    return {"nm": "radial motion [nm]", "count": "correction [count]"}.get(unit, f"[{unit}]")


#: pixel columns a plotted series is binned to: wider than a plot at the report's
#: resolution (7.2 in at 110 dpi: 792 px); a longer series is drawn as the smallest and
#: largest value of each column, so the envelope drawn is the data's exactly (a long
#: curve comes binned so: longcurves.py)
COLUMNS = longcurves.COLUMNS


def _columns(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The column of each value of ``x`` (ascending) and where each column starts."""
    edges = np.linspace(x[0], x[-1], COLUMNS + 1)
    col = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, COLUMNS - 1)
    return col, np.flatnonzero(np.r_[True, col[1:] != col[:-1]])


def min_max_binned(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` (``x`` ascending) as at most 2 :data:`COLUMNS` points: each pixel
    column's smallest and largest ``y`` in the order they occur (all points when there
    are no more than that). Non-finite values are left out of a binned series."""
    if x.size <= 2 * COLUMNS:
        return x, y
    ok = np.isfinite(y) & np.isfinite(x)
    x, y = x[ok], y[ok]
    if x.size <= 2 * COLUMNS:
        return x, y
    col, starts = _columns(x)
    order = np.lexsort((y, col))                 # by column, then by value
    ends = np.r_[starts[1:], x.size] - 1
    lo, hi = order[starts], order[ends]
    keep = np.sort(np.unique(np.concatenate([lo, hi])))
    return x[keep], y[keep]


def band_binned(x: np.ndarray, low: np.ndarray, high: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A band (``low`` .. ``high`` over ascending ``x``) as each pixel column's lowest
    ``low`` and highest ``high`` at the column's first ``x`` (as it is when short)."""
    if x.size <= 2 * COLUMNS:
        return x, low, high
    _, starts = _columns(x)
    return x[starts], np.fmin.reduceat(low, starts), np.fmax.reduceat(high, starts)


def deviation_plot(curves: Sequence[Curve], title: str) -> Figure:
    """Deviation curves against angle with the U band (the curve's k) where known."""
    fig = new_figure()
    ax = fig.add_subplot()
    for i, c in enumerate(curves):
        x = _angle_deg(c)
        order = np.argsort(x)
        x, y = x[order], c.values[order]
        color = COLORS[i % len(COLORS)]
        sparse = c.values.size <= 100
        ax.plot(*min_max_binned(x, y), "o-" if sparse else "-", ms=3.5, lw=1.2, color=color,
                label=f"{c.name} (p-p {c.figures.pp:.3g}, s {c.figures.std:.3g})")
        if c.u is not None:
            U = c.k * np.asarray(c.u)[order]
            ax.fill_between(*band_binned(x, y - U, y + U), color=color, alpha=0.2, lw=0,
                            label=f"{c.name} ± U (k={c.k:.3g})")
    ax.axhline(0, color="0.6", lw=0.6)
    ax.set_xlabel(_angle_label(curves[0]))
    ax.set_ylabel(_unit_label(curves[0].unit, in_length(curves[0])))
    if curves[0].domain != "period":
        ax.set_xlim(0, 360)
        ax.set_xticks(np.arange(0, 361, 45))
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    _legend(ax, len(curves))
    return fig


def _legend(ax: Any, count: int, markerscale: float = 1.0) -> None:
    if count > 3:   # many curves: beside the plot from its top, not over the data
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                  markerscale=markerscale, labelspacing=0.25, borderaxespad=0.0)
    else:
        ax.legend(fontsize=7, loc=_quiet_corner(ax), markerscale=markerscale)


Corner = Literal["upper right", "upper left", "lower right", "lower left", "upper center",
                 "lower center", "center right", "center left"]


def _quiet_corner(ax: Any, size_pt: float = 7.0) -> Corner:
    """The corner or edge of the axes where a legend of its labels hides the fewest plotted
    points and vertices of bars and bands. (matplotlib's "best" tests every vertex of
    every U band at each of nine places, and took a fifth of a second on one plot.)"""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    parts = [np.asarray(line.get_xydata(), np.float64).reshape(-1, 2) for line in ax.lines
             if line.get_transform() is ax.transData]           # not the 0 line (axhline)
    parts += [p.vertices for c in ax.collections for p in c.get_paths()]   # bars, bands
    xy = np.concatenate(parts) if parts else np.empty((0, 2))
    u = (xy[:, 0] - x0) / ((x1 - x0) or 1.0)
    v = (xy[:, 1] - y0) / ((y1 - y0) or 1.0)
    # the legend's size [axes fraction] from its labels (as _legend_width_in measures)
    labels = ax.get_legend_handles_labels()[1]
    wide_in, high_in = (ax.figure.get_size_inches() * ax.get_position().size)
    w = (0.6 * size_pt / 72.0 * max((len(t) for t in labels), default=0) + 0.6) / wide_in
    h = (1.6 * size_pt / 72.0 * len(labels) + 0.15) / high_in
    right, top, left, low = u > 1 - w, v > 1 - h, u < w, v < h
    middle, centre = np.abs(u - 0.5) < w / 2, np.abs(v - 0.5) < h / 2
    places: dict[Corner, np.ndarray] = {
        "upper right": right & top, "upper left": left & top, "lower right": right & low,
        "lower left": left & low, "upper center": middle & top, "lower center": middle & low,
        "center right": right & centre, "center left": left & centre}
    return min(places, key=lambda k: int(np.count_nonzero(places[k])))  # a corner on a tie


def _last_significant(rows: Sequence[SpectrumRows]) -> int:
    """Highest order whose amplitude reaches 2 % of the largest (at least 10)."""
    top = max(float(np.max(sp.amplitude[sp.n > 0], initial=0.0)) for sp in rows) or 1.0
    last = max((int(sp.n[(sp.n > 0) & (sp.amplitude >= 0.02 * top)].max(initial=0))
                for sp in rows), default=0)
    return max(10, last + 2)


def spectrum_plot(rows: Sequence[SpectrumRows], title: str, per: str = "rev") -> Figure:
    """Harmonic amplitudes [arcsec] against order, with U = k u as error bars."""
    fig = new_figure()
    ax = fig.add_subplot()
    width = 0.8 / max(1, len(rows))
    last = min(_last_significant(rows), max(int(sp.n.max()) for sp in rows))
    for i, sp in enumerate(rows):
        keep = (sp.n > 0) & (sp.n <= last)  # the orders beyond the axis are not drawn
        n = sp.n[keep] + (i - (len(rows) - 1) / 2) * width
        _bars(ax, n, sp.amplitude[keep], width, COLORS[i % len(COLORS)], sp.curve)
        if sp.u is not None:
            ax.errorbar(n, sp.amplitude[keep], yerr=sp.k * sp.u[keep], fmt="none", ecolor="k",
                        elinewidth=0.6, capsize=1.5)
    ax.set_xlabel(f"harmonic order n [1/{per}]")
    ax.set_ylabel(f"amplitude [{label(rows[0].unit)}]")
    ax.autoscale_view()
    ax.set_ylim(bottom=0)
    ax.set_xlim(0, last + 0.6)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, axis="y")
    if len(rows) > 1 or rows[0].u is not None:
        _legend(ax, len(rows))
    return fig


def _bars(ax: Any, x: np.ndarray, height: np.ndarray, width: float, color: str,
          name: str) -> None:
    """Bars of ``height`` centred on ``x`` as one collection (a hundred bars as one
    artist, not a hundred rectangles each placed and drawn on its own)."""
    from matplotlib.collections import PolyCollection

    x0, x1, zero = x - width / 2, x + width / 2, np.zeros_like(height)
    verts = np.stack([np.column_stack(c) for c in ((x0, zero), (x0, height), (x1, height),
                                                   (x1, zero))], axis=1)
    ax.add_collection(PolyCollection(list(verts), facecolors=color, edgecolors="none",
                                     label=name))


def harmonics_rows(curves: Sequence[Curve]) -> list[SpectrumRows]:
    """The harmonics of curves as spectrum rows (for :func:`spectrum_plot`)."""
    return [SpectrumRows(c.name, c.harmonics.n, c.harmonics.amplitude, c.harmonics.phase,
                         unit=c.unit)
            for c in curves if c.harmonics is not None and c.harmonics.resolved]


def radial_polar_plot(curves: Sequence[Curve], title: str) -> Figure:
    """Radial error motion [nm] on a polar plot around a base circle.

    With x and y curves the plotted error is the radial motion in a direction that
    turns with the spindle, r = x cos(theta) + y sin(theta); a single curve is
    plotted as it is. Radial tick labels are nm of error (base circle = 0).
    """
    fig = new_figure((4.8, 4.8))
    ax = cast("PolarAxes", fig.add_subplot(projection="polar"))
    byname = {c.name.lower(): c for c in curves}
    xs = [c for n, c in byname.items() if n.endswith("x")]
    ys = [c for n, c in byname.items() if n.endswith("y")]
    if xs and ys and xs[0].digest is not None and xs[0].digest.polar is not None:
        traces = [("radial (x cos θ + y sin θ)", *xs[0].digest.polar)]   # a long curve's
    elif xs and ys:
        cx, cy = xs[0], ys[0]
        theta = np.asarray(cx.angle)
        err = cx.values * np.cos(theta) + np.interp(theta, cy.angle, cy.values) * np.sin(theta)
        traces = [("radial (x cos θ + y sin θ)", theta, err)]
    else:
        traces = [(c.name, np.asarray(c.angle), c.values) for c in curves]
    span = max(float(np.ptp(t[2])) for t in traces) or 1.0
    lo = min(float(np.min(t[2])) for t in traces)
    base = 1.5 * span
    for i, (name, th, e) in enumerate(traces):
        order = np.argsort(th)
        th_c = np.append(th[order], th[order][0] + 2 * np.pi)
        r = np.append(e[order], e[order][0]) - lo + base
        ax.plot(*min_max_binned(th_c, r), color=COLORS[i % len(COLORS)], lw=1.0, label=name)
    ax.plot(np.linspace(0, 2 * np.pi, 361), np.full(361, base), color="0.6", lw=0.6, ls="--")
    ticks = np.linspace(base, base + span, 3)
    ax.set_rticks(ticks)
    ax.set_yticklabels([f"{t - base + lo:.0f} nm" for t in ticks], fontsize=7)
    ax.set_rlim(0, base + 1.1 * span)
    ax.set_xlabel("spindle angle [deg]; radius: radial error motion [nm]", fontsize=8,
                  labelpad=14)
    ax.set_title(f"{title}\n{traces[0][0] if len(traces) == 1 else ''}", fontsize=9)
    if len(traces) > 1:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.05, 1.0))
    return fig


def lissajous_plot(signals: dict[str, tuple[np.ndarray, np.ndarray]], title: str) -> Figure:
    """Raw quadrature signals: sin [V] against cos [V] for every head."""
    fig = new_figure((4.8, 4.8))
    ax = fig.add_subplot()
    for i, (head, (c, s)) in enumerate(signals.items()):
        ax.plot(c, s, ".", ms=1.0, color=COLORS[i % len(COLORS)], label=head)
    ax.set_aspect("equal")
    ax.set_xlabel("cos signal (I) [V]")
    ax.set_ylabel("sin signal (Q) [V]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    _legend(ax, len(signals), markerscale=6)
    return fig


def _finish(ax: Any, xlabel: str, ylabel: str, title: str) -> None:
    """The closing of a plot of one axes: both axes' labels (with their units), the
    title, a light grid and the legend in the corner its data leave free."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc=_quiet_corner(ax))


def vdi_plot(vdi: Any, title: str) -> Figure:
    """VDI/DGQ 3441: mean position deviation x_j with the band +/-(U_j + Ps_j)/2 whose
    range is P, and the mean deviation of each direction."""
    fig = new_figure()
    ax = fig.add_subplot()
    o = np.argsort(vdi.positions)        # the 0 deg target may stand at 360 - epsilon
    ax.errorbar(vdi.positions[o], vdi.mean[o], yerr=((vdi.U + vdi.Ps) / 2)[o], fmt="o-", ms=3,
                lw=1, capsize=2, color=COLORS[2], label="x_j ± (U_j + Ps_j)/2")
    for mean, name, color in ((vdi.mean_up, "up (+)", COLORS[0]),
                              (vdi.mean_down, "down (-)", COLORS[1])):
        ax.plot(vdi.positions, mean, ".", ms=4, color=color, label=f"mean {name}", zorder=3)
    _finish(ax, f"target position [{vdi.position_unit}]",
            f"position deviation [{label(vdi.unit)}]", title)
    return fig


def iso_plot(iso: Any, title: str) -> Figure:
    """ISO 230-2: mean positioning deviation per direction with the +/-2 s bands."""
    fig = new_figure()
    ax = fig.add_subplot()
    for d, name, color, shift in ((iso.up, "up (+)", COLORS[0], -0.4),
                                  (iso.down, "down (-)", COLORS[1], 0.4)):
        if d is None:
            continue
        o = np.argsort(iso.positions)    # the 0 deg target may stand at 360 - epsilon
        x = iso.positions[o] + (shift if iso.is_bidirectional else 0)
        ax.errorbar(x, d.mean[o], yerr=2 * d.s[o], fmt="o-", ms=3, lw=1, capsize=2, color=color,
                    label=f"mean {name} ± 2s")
    _finish(ax, f"target position [{iso.position_unit}]",
            f"positioning deviation [{label(iso.unit)}]", title)
    return fig


def compare_plot(pairs: Sequence[tuple[str, Curve]], title: str) -> Figure:
    """Curves of several inputs on one plot (before/after compensation)."""
    fig = new_figure()
    ax = fig.add_subplot()
    unit = label(pairs[0][1].unit)
    for i, (name, c) in enumerate(pairs):
        x = _angle_deg(c)
        order = np.argsort(x)
        ax.plot(*min_max_binned(x[order], c.values[order]),
                "o-" if c.values.size <= 100 else "-", ms=3, lw=1.1,
                color=COLORS[i % len(COLORS)],
                label=f"{name} (p-p {c.figures.pp:.3g} {unit}, s {c.figures.std:.3g} {unit})")
    ax.axhline(0, color="0.6", lw=0.6)
    ax.set_xlim(0, 360)
    ax.set_xticks(np.arange(0, 361, 45))
    _finish(ax, "angle [deg]", f"deviation [{unit}]", title)
    return fig


def history_plot(times: np.ndarray, series: dict[str, np.ndarray], title: str,
                 bad: np.ndarray | None = None, unit: str = "arcsec") -> Figure:
    """Figures of the nightly runs against time [UTC], drift runs marked."""
    fig = new_figure()
    ax = fig.add_subplot()
    for i, (name, y) in enumerate(series.items()):
        ax.plot(times, y, "o-", ms=3, lw=1, color=COLORS[i % len(COLORS)], label=name)
        if bad is not None and np.any(bad):
            ax.plot(times[bad], y[bad], "x", ms=8, color="k")
    _finish(ax, "run time [UTC]", f"figure [{label(unit)}]", title)
    fig.autofmt_xdate()
    return fig


def section_figures(s: Section, top: int = 5) -> list[tuple[str, Figure]]:
    """Every plot of one section, with a caption."""
    out: list[tuple[str, Figure]] = []
    name = s.source.rsplit("/", 1)[-1] or s.source   # the file; the heading has its path
    dev = [c for c in s.curves if c.unit in ANGLE_UNITS or in_length(c)]  # a scale's in nm
    radial = [c for c in s.curves if c.unit == "nm" and not in_length(c)]
    other = [c for c in s.curves if c.unit not in ANGLE_UNITS and c.unit != "nm"]
    if dev:
        if s.domain == "period":
            out.append(("Interpolation error per head within one signal period",
                        deviation_plot(dev, f"interpolation error — {name}")))
        else:
            ks = sorted({c.k for c in dev if c.u is not None})
            label = f"with U band (k={'/'.join(f'{k:.3g}' for k in ks)})" if ks else ""
            out.append((f"Deviation curve {label}".strip(),
                        deviation_plot(dev, f"deviation — {name}")))
        rows = harmonics_rows(dev)
        if rows:
            out.append(("Spectrum of the deviation (amplitude A of A cos(n x + p))",
                        spectrum_plot(rows, f"harmonics — {name}",
                                      "period" if s.domain == "period" else "rev")))
    if radial:
        out.append(("Spindle radial error motion (polar)",
                    radial_polar_plot(radial, f"radial motion — {name}")))
        out.append(("Radial error motion against angle", deviation_plot(radial, name)))
    for c in other:
        out.append((f"{c.name} against angle", deviation_plot([c], name)))
    if s.spectra:
        per = "period" if s.domain == "period" else "rev"
        ks = sorted({sp.k for sp in s.spectra if sp.u is not None}) or [2.0]
        out.append((f"Spectrum (error bars: U, k={'/'.join(f'{k:.3g}' for k in ks)})",
                    spectrum_plot(s.spectra, f"spectrum — {name}", per)))
    if s.iso is not None:
        out.append(("ISO 230-2 mean positioning deviations with ±2s",
                    iso_plot(s.iso, f"ISO 230-2 — {name}")))
    if s.vdi is not None:
        out.append(("VDI/DGQ 3441 mean position deviations with ±(U_j + Ps_j)/2",
                    vdi_plot(s.vdi, f"VDI/DGQ 3441 — {name}")))
    if s.signals:
        out.append(("Lissajous plot of the raw quadrature signals",
                    lissajous_plot(s.signals, f"signals — {name}")))
    return out

"""Plots of long series are drawn binned to the plot's pixel columns, each column's
smallest and largest value kept: the envelope drawn is the data's exactly."""

from __future__ import annotations

import numpy as np

from enctools.report import plots


def test_a_short_series_is_drawn_as_it_is():
    x = np.linspace(0, 360, 2 * plots.COLUMNS)
    y = np.sin(x)
    bx, by = plots.min_max_binned(x, y)
    assert bx is x and by is y
    assert plots.band_binned(x, y - 1, y + 1)[0] is x


def test_a_long_series_keeps_each_columns_extremes():
    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(0, 360, 200_000))
    y = np.sin(np.deg2rad(x)) + rng.normal(0, 0.2, x.size)
    bx, by = plots.min_max_binned(x, y)
    assert bx.size <= 2 * plots.COLUMNS and np.all(np.diff(bx) >= 0)
    assert by.max() == y.max() and by.min() == y.min()
    col, starts = plots._columns(x)
    for c in (0, 17, 500, plots.COLUMNS - 1):
        inside = col == c
        kept = (bx >= x[inside][0]) & (bx <= x[inside][-1])
        assert by[kept].min() == y[inside].min() and by[kept].max() == y[inside].max()
    lx, lo, hi = plots.band_binned(x, y - 0.1, y + 0.1)
    assert lx.size == starts.size and lo.min() == (y - 0.1).min() and hi.max() == (y + 0.1).max()


def test_a_deviation_plot_of_many_points_draws_at_most_two_a_column():
    from enctools.report.sections import Curve, curve_figures

    x = np.linspace(0, 2 * np.pi, 300_000, endpoint=False)
    c = Curve("e", "arcsec", "deviation", x, np.sin(x), curve_figures(np.sin(x)))
    c.u = np.full(x.size, 0.1)
    fig = plots.deviation_plot([c], "t")
    line = fig.axes[0].lines[0]
    assert len(line.get_xdata()) <= 2 * plots.COLUMNS

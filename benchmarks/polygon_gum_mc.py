"""Monte Carlo (JCGM 101:2008, GUM Supplement 1) of the polygon run's measurement model
that enc report propagates through GTC (enctools/methods/polygon_gum.py).

The model of seed 001's polygon run (ciomp-23bit: 24 faces, 5 readings a position, 2
heads; the run's figures as enc points records them for the bundled rig's default run,
the rig's declarations for the polygon and the autocollimator):

    D_j = x_j + (r_j - r_0) + (1/N) sum_k (Q_jk - Q_0k) - (delta_j - delta_0)
          - (a_j - a_0) kappa

Each draw takes every input from its distribution (JCGM 101 6.4): the repeatabilities
r_i from one pooled s on nu degrees of freedom, a multivariate t (one chi-square scale a
draw, JCGM 101 6.4.9 for the shared estimate), the quantisation and the Type B faces
and scale normal as declared, a Type A face certificate (a closure's) as the same
multivariate t on its dof. Per point, for the difference of two points and for p-p
(the difference of the extreme points), the fraction of draws inside the GUM's U = k u
(GTC) and the Monte Carlo 95 % half-width are printed; make bench requires the coverage
of every figure within 94..96 % over >= 1e5 draws.

    .venv/bin/python benchmarks/polygon_gum_mc.py                  # 200,000 draws
    .venv/bin/python benchmarks/polygon_gum_mc.py --draws 100000 --closure

tests/lib/methods/test_polygon_gum_mc.py runs it on fewer draws. Units: arcsec.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from enctools.data.rig import load_rig
from enctools.data.uncertainty import declarations
from enctools.methods.budget import PolygonRun, dithered_quantisation
from enctools.methods.polygon_gum import Faces, PointsModel, propagate

#: the coverage make bench requires of each expanded uncertainty
BAND = (0.94, 0.96)
F = 24
#: what enc points records of the bundled ciomp-23bit rig's default run (polygon_run)
RUN = PolygonRun(s_arcsec=0.0479896561227388, dof=96, readings=5,
                 span_arcsec=3.9935479329974415, lsb_arcsec=0.1544952392578125, heads=2,
                 head_s_arcsec=0.05857590779774766)
#: a closure's face certificate of that rig (enc closure: u face, dof)
CLOSURE = (0.0051327, 506.0)


def model_inputs(closure: bool) -> tuple[np.ndarray, np.ndarray, Faces, object]:
    """The run's deviations and a_j - a_0 [arcsec] (a smooth curve of the rig's size:
    their values do not enter the uncertainty but the autocollimator's offsets do), the
    faces and the scale declaration."""
    declared = declarations(load_rig("ciomp-23bit").to_dict()["uncertainty"], "ciomp-23bit")
    t = 2 * np.pi * np.arange(F) / F
    x = 2.5 * np.sin(t + 0.17) + 1.0 * np.sin(2 * t + 1.1)
    x -= x[0]
    ac = -x * RUN.span_arcsec / np.max(np.abs(x))
    faces = Faces(np.full(F, CLOSURE[0]), CLOSURE[1]) if closure else \
        Faces(np.full(F, declared["polygon"].standard))
    return x, ac, faces, declared["autocollimator"]


def _t_scaled(rng: np.random.Generator, draws: int, shape: int, u: np.ndarray | float,
              dof: float) -> np.ndarray:
    """Draws of ``shape`` inputs u t_nu from one estimate on ``dof`` (one chi-square a draw
    shared by the inputs: a multivariate t; JCGM 101 6.4.9.2 scales t by u itself);
    normal when ``dof`` is infinite."""
    z = rng.standard_normal((draws, shape)) * u
    if math.isinf(dof):
        return z
    return z * np.sqrt(dof / rng.chisquare(dof, (draws, 1)))


def draws_of_d(ac: np.ndarray, faces: Faces, kappa_u: float,
               draws: int, rng: np.random.Generator) -> np.ndarray:
    """``draws`` x F draws of D_j - x_j [arcsec] from the inputs' distributions."""
    q = RUN.lsb_arcsec
    u_q = dithered_quantisation(q, math.sqrt(max(RUN.head_s_arcsec ** 2 - q * q / 12.0, 0.0)))
    r = _t_scaled(rng, draws, F, RUN.s_arcsec / math.sqrt(RUN.readings), RUN.dof)
    quant = rng.standard_normal((draws, F, RUN.heads)).mean(axis=2) * u_q
    delta = _t_scaled(rng, draws, F, faces.u_arcsec, faces.dof)
    kappa = rng.standard_normal((draws, 1)) * kappa_u
    d = (r - r[:, :1]) + (quant - quant[:, :1]) - (delta - delta[:, :1]) - ac[None, :] * kappa
    return d


def monte_carlo(draws: int, seed: int = 0, closure: bool = False, chunk: int = 50_000
                ) -> dict[str, tuple[float, float, float]]:
    """Coverage, the GUM's U and the Monte Carlo 95 % half-width of each figure: the
    points (the least coverage over them), the difference of the pair of the largest U,
    p-p."""
    x, ac, faces, kappa = model_inputs(closure)
    m: PointsModel = propagate(x, ac, np.arange(F), RUN, faces, kappa)
    rng = np.random.default_rng(seed)
    parts = [draws_of_d(ac, faces, kappa.standard, min(chunk, draws - i), rng)
             for i in range(0, draws, chunk)]
    d = np.concatenate(parts)
    (i, j), (a, b) = m.pair, m.extremes
    out = {}
    inside = np.abs(d[:, 1:]) <= (m.k * m.u)[None, 1:]
    worst = int(np.argmin(inside.mean(axis=0))) + 1
    out[f"point of the least coverage (j = {worst})"] = (
        float(inside.mean(axis=0).min()), float(m.k[worst] * m.u[worst]),
        float(np.quantile(np.abs(d[:, worst]), 0.95)))
    for name, y, fig in ((f"difference of points {i} and {j}", d[:, i] - d[:, j],
                          m.difference), (f"p-p (points {a} - {b})", d[:, a] - d[:, b], m.pp)):
        out[name] = (float(np.mean(np.abs(y) <= fig.U)), fig.U,
                     float(np.quantile(np.abs(y), 0.95)))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--draws", type=int, default=200_000, help="Monte Carlo draws (>= 1e5)")
    ap.add_argument("--closure", action="store_true",
                    help="the faces from a closure's certificate (Type A, 506 dof)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    ok = True
    for closure in (False, True) if not args.closure else (True,):
        res = monte_carlo(args.draws, seed=1, closure=closure)
        print(f"polygon run model (JCGM 101, {args.draws} draws; faces "
              f"{'from a closure, Type A' if closure else 'as the rig declares'}):")
        print(f"  {'figure':42s} {'coverage':>9s} {'U (GTC)':>9s} {'MC 95 %':>9s}")
        for name, (cov, U, half) in res.items():
            good = BAND[0] <= cov <= BAND[1]
            ok &= good
            print(f"  {name:42s} {cov:9.4f} {U:9.5f} {half:9.5f} {'ok' if good else 'OUT'}")
    print(f"band {BAND[0]:.2f}..{BAND[1]:.2f}: {'ok' if ok else 'OUT'}; "
          f"{time.perf_counter() - t0:.1f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

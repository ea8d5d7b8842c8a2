"""The polygon run's model through GTC (enctools/methods/polygon_gum.py): the same u_c,
nu_eff, k and U as the hand budget (methods/budget.py) to 8 digits, and the covariance,
differences and harmonics against an independent implementation. Units: arcsec."""

from __future__ import annotations

import math

import numpy as np
import pytest

from enctools.data.polygon import certificate_text, read_certificate
from enctools.data.uncertainty import Declaration
from enctools.errors import DataError
from enctools.methods.budget import PolygonRun, dithered_quantisation, polygon_run_budget
from enctools.methods.polygon_gum import Faces, propagate
from enctools.report.budget import certificate_face

F = 24
RUN = PolygonRun(s_arcsec=0.048, dof=96, readings=5, span_arcsec=3.99, lsb_arcsec=0.1545,
                 heads=2, head_s_arcsec=0.0586)
KAPPA = Declaration("autocollimator", 0.2, "%", "normal", k=2.0, source="AC")
POLYGON = Declaration("polygon", 0.05, "arcsec", "normal", source="P")
RNG = np.random.default_rng(7)
X = np.r_[0.0, RNG.normal(0.0, 1.5, F - 1)]
AC = np.r_[0.0, RNG.uniform(-3.9, 3.9, F - 2), -3.99]     # the last at the span
FACE = np.arange(F)


def _close(a: float, b: float) -> None:
    assert a == pytest.approx(b, rel=1e-8)


@pytest.mark.parametrize("face, faces", [
    (POLYGON, Faces(np.full(F, 0.05))),
    # a closure's faces: Type A, every face's u from one s on 506 dof (one GTC ensemble)
    (Declaration("polygon", 0.0051, "arcsec", "normal", dof=506.0, kind="A"),
     Faces(np.full(F, 0.0051), 506.0))])
def test_gtc_gives_the_budget_u_c_nu_eff_k_and_U_to_8_digits(face, faces):
    budget = polygon_run_budget({"autocollimator": KAPPA}, RUN, face)
    model = propagate(X, AC, FACE, RUN, faces, KAPPA)
    last = F - 1            # |a_j - a_0| = the span: the budget's row holds that point
    _close(model.u[last], budget.u_c)
    _close(model.dof[last], budget.nu_eff)
    _close(model.k[last], budget.k)
    _close(model.k[last] * model.u[last], budget.U)
    assert model.u[0] == 0.0 and np.all(model.u[1:] <= budget.u_c * (1 + 1e-12))


def _covariance(u_face: np.ndarray) -> np.ndarray:
    """The points' covariance from the model written out term by term (no GTC)."""
    u_r2 = RUN.s_arcsec ** 2 / RUN.readings
    q = RUN.lsb_arcsec
    u_q2 = dithered_quantisation(q, math.sqrt(RUN.head_s_arcsec ** 2 - q * q / 12)) ** 2
    own = u_r2 + u_q2 / RUN.heads            # one position's repeatability and quantisation
    c = -AC
    cov = np.empty((F, F))
    for i in range(F):
        for j in range(F):
            if 0 in (i, j):
                cov[i, j] = 0.0
                continue
            cov[i, j] = (own * ((i == j) + 1) + u_face[FACE[i]] ** 2 * (FACE[i] == FACE[j])
                         + u_face[0] ** 2 + c[i] * c[j] * KAPPA.standard ** 2)
    return cov


def test_covariance_between_points_from_the_datum_and_the_scale():
    u_face = RNG.uniform(0.02, 0.06, F)
    model = propagate(X, AC, FACE, RUN, Faces(u_face), KAPPA)
    cov = _covariance(u_face)
    assert np.allclose(model.cov, cov, rtol=1e-10, atol=1e-16)
    lo, hi = model.r_range()
    assert 0.3 < lo < hi < 0.8      # the datum's terms: about half of each variance
    i, j = model.pair
    var = np.diag(cov)[:, None] + np.diag(cov)[None, :] - 2 * cov
    _close(model.difference.u, math.sqrt(var.max()))
    _close(model.difference.u, math.sqrt(var[i, j]))
    a, b = model.extremes
    assert (a, b) == (int(np.argmax(X)), int(np.argmin(X)))
    _close(model.pp.u, math.sqrt(var[a, b]))
    # an independent treatment of two points would overstate it by about sqrt 2
    assert model.difference.u < 0.8 * math.sqrt(cov[i, i] + cov[j, j])


def test_harmonic_amplitudes_and_their_u_linearised():
    u_face = np.full(F, 0.05)
    model = propagate(X, AC, FACE, RUN, Faces(u_face), KAPPA)
    cov = _covariance(u_face)
    t = 2 * np.pi * np.arange(F) / F
    assert list(model.orders) == list(range(1, 12))
    for n, amp, fig in zip(model.orders, model.amplitude, model.harmonics, strict=True):
        a, b = 2 / F * np.sum(X * np.cos(n * t)), 2 / F * np.sum(X * np.sin(n * t))
        _close(amp, math.hypot(a, b))
        grad = 2 / F * (a * np.cos(n * t) + b * np.sin(n * t)) / math.hypot(a, b)
        _close(fig.u, math.sqrt(grad @ cov @ grad))


def test_a_closing_point_at_360_deg_is_the_datum_face_again():
    x = np.r_[X, 0.02]
    model = propagate(x, np.r_[AC, 0.01], np.r_[FACE, 0], RUN, Faces(np.full(F, 0.05)),
                      KAPPA)
    # its face cancels against the datum's: only repeatability, quantisation, scale
    assert model.u[F] < model.u[1] and model.orders.size == 0


def test_a_closure_certificate_is_type_a_on_its_dof(tmp_path):
    path = tmp_path / "faces.csv"
    path.write_text(certificate_text(np.zeros(F), np.full(F, 0.0051), "closure run",
                                     "circle closure", type_a_dof=506))
    cert = read_certificate(str(path))
    assert (cert.kind, cert.dof) == ("A", 506.0)
    face = certificate_face({"polygon_certificate": cert.meta()})
    assert (face.kind, face.dof, face.value) == ("A", 506.0, pytest.approx(0.0051))
    rows = polygon_run_budget({}, RUN, face).contributions
    assert [r.kind for r in rows if "polygon" in r.name] == ["A"]    # one estimate: one row
    path.write_text(path.read_text().replace("# dof: 506\n", ""))
    with pytest.raises(DataError, match="Type A certificate needs the degrees of freedom"):
        read_certificate(str(path))


def test_an_external_certificate_stays_type_b(tmp_path):
    path = tmp_path / "faces.csv"
    path.write_text(certificate_text(np.zeros(F), np.full(F, 0.02), "PTB 1", "PTB"))
    face = certificate_face({"polygon_certificate": read_certificate(str(path)).meta()})
    assert (face.kind, face.dof) == ("B", math.inf)

"""The polygon and autocollimator method's terms a rig declares beyond the faces and the
scale (enc-rig(5) UNCERTAINTY; issue 41 item 2), with each one's place in the model of a
point D_j against the datum (:mod:`enctools.methods.budget`, :mod:`enctools.methods.
polygon_gum`). Every one is an angle [arcsec at the autocollimator's reading]:

- ``pair``: an error of each reading, independent from position to position, that the
  point and the datum both carry: D_j gains x_j - x_0, u sqrt 2 (one row, c = sqrt 2).
  The autocollimator's resolution (its display's digit, rectangular), its noise and the
  air's turbulence beyond the scatter of the readings of a stop (slower than they are:
  W. T. Estler, J. Res. NIST 103 (1998) 141-151), the faces' flatness (the aperture sees
  a mean normal that differs from the face's angle) and the pyramidal error (a face's
  tilt: with the autocollimator's own tilt an error of its horizontal reading).
- ``point``: at the point only (c = -1): the alignment of the polygon to the axis, the
  angle error its residual eccentricity or tilt makes at a target.
- ``common``: one value for every point but the datum (c = 1): the zero's drift with
  temperature over the run, the angle it may move between the datum and any point.
"""

from __future__ import annotations

from collections.abc import Collection

#: quantity -> (its row's name, how it enters: "pair", "point" or "common")
POLYGON_TERMS: dict[str, tuple[str, str]] = {
    "autocollimator_resolution": ("autocollimator resolution at the point and the datum",
                                  "pair"),
    "autocollimator_noise": ("autocollimator noise and air turbulence beyond the readings' "
                             "scatter, at the point and the datum", "pair"),
    "face_flatness": ("flatness of the faces at the point and the datum", "pair"),
    "pyramidal": ("pyramidal error of the faces at the point and the datum", "pair"),
    "alignment": ("alignment of the polygon to the axis", "point"),
    "temperature_drift": ("drift of the zero with temperature over the run", "common"),
}

#: the sensitivity [arcsec per arcsec] of each kind's one row in a budget
SENSITIVITY = {"pair": 2.0 ** 0.5, "point": -1.0, "common": 1.0}

#: what the model leaves out when a rig declares none of a quantity, in the note's words
NOT_DECLARED_WORDS: dict[str, str] = {
    "autocollimator_resolution": "the autocollimator's resolution",
    "autocollimator_noise": "the autocollimator's noise beyond the readings' scatter and air "
                            "turbulence",
    "face_flatness": "the faces' flatness",
    "pyramidal": "pyramidal error",
    "alignment": "tilt (cosine error) and eccentricity of the polygon",
    "temperature_drift": "temperature and drift over the run",
}
#: what no rig key declares yet (always in the note)
NEVER_DECLARED = ("the autocollimator's non-linearity beyond its scale",
                  "optical asymmetry (no measurement in the reversed position)")


def not_declared(declared: Collection[str], closed: bool = False) -> str:
    """The note naming what the polygon model leaves out of U: every term of
    :data:`POLYGON_TERMS` the rig does not declare, and what none can declare yet;
    ``closed``: a closing reading bounds the drift (its own row), only temperature left."""
    parts = [w for q, w in NOT_DECLARED_WORDS.items() if q not in declared]
    if closed:
        parts = ["temperature" if p.startswith("temperature") else p for p in parts]
    return "not declared, so not in U: " + "; ".join([*parts, *NEVER_DECLARED])

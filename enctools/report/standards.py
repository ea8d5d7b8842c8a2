"""One source for each reference standard of a certificate.

The reference standards a certificate lists are those of its file's ``[[reference]]``
tables (enc-certificate(5)); a budget row of a quantity a reference standard realises
(its ``quantity``: a polygon's faces, an autocollimator's scale, a reference encoder's
calibrated curve or, used without it, its accuracy, a probe's calibration) takes its
identity from that table: its name,
serial, certificate number and due date. A certificate whose budget has such a row with
no reference standard declared for it, or whose data were corrected with a
certificate other than the one it lists, is refused (one DataError line), so that the
document names each standard once and the same way everywhere.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
from typing import Any

from enctools.data.uncertainty import QUANTITIES
from enctools.errors import DataError
from enctools.methods.budget import Budget, combine
from enctools.report.certificate import Certificate

#: the declared quantities that a reference standard realises (its certificate is the
#: row's source); the others (an arm's length, a temperature, a head's mounting) are
#: the laboratory's own knowledge
STANDARD_QUANTITIES = ("polygon", "autocollimator", "probe", "reference_encoder",
                       "reference_encoder_uncorrected")
#: a quantity the standard of another realises when none names it: an encoder used
#: without its calibrated curve is the same standard as with it (its accuracy as read)
SAME_STANDARD = {"reference_encoder_uncorrected": "reference_encoder"}


def identity(ref: dict[str, Any]) -> str:
    """A reference standard as a budget row names it: name, serial, certificate, due."""
    parts = [str(ref.get("name", "reference standard"))]
    if ref.get("serial"):
        parts.append(f"serial {ref['serial']}")
    if ref.get("certificate"):
        parts.append(f"certificate {ref['certificate']}")
    due = ref.get("due")
    if isinstance(due, _dt.date):
        parts.append(f"due {due.isoformat()}")
    return ", ".join(parts)


def by_quantity(cert: Certificate) -> dict[str, dict[str, Any]]:
    """The reference standards of the file by the quantity each realises; DataError for
    an unknown quantity or one claimed twice."""
    out: dict[str, dict[str, Any]] = {}
    for ref in cert.references:
        q = ref.get("quantity")
        if q is None:
            continue
        if q not in QUANTITIES:
            msg = (f"{cert.source}: [[reference]] {ref.get('name', '')!r}: quantity {q!r} is "
                   f"none of {', '.join(QUANTITIES)}")
            raise DataError(msg)
        if q in out:
            msg = (f"{cert.source}: two [[reference]] tables realise quantity {q!r} "
                   f"({out[q].get('name', '')!r}, {ref.get('name', '')!r})")
            raise DataError(msg)
        out[q] = ref
    return out


def apply(report: Any, cert: Certificate) -> None:
    """Each section's budget with the identity of its reference standards from
    ``cert`` (in place); DataError when a row of a standard's quantity has none, or
    the data name another certificate of it."""
    refs = by_quantity(cert)
    for s in report.sections:
        if s.budget is not None:
            s.budget = _identified(s.budget, refs, cert, s)


def _identified(budget: Budget, refs: dict[str, dict[str, Any]], cert: Certificate,
                s: Any) -> Budget:
    rows = []
    for c in budget.contributions:
        if c.quantity not in STANDARD_QUANTITIES:
            rows.append(c)
            continue
        ref = refs.get(c.quantity) or refs.get(SAME_STANDARD.get(c.quantity, ""))
        if ref is None:
            msg = (f"{s.source}: the budget's row {c.name!r} ({c.source}) is of a reference "
                   f"standard that {cert.source} does not list: give its [[reference]] "
                   f"with quantity = \"{SAME_STANDARD.get(c.quantity, c.quantity)}\"")
            raise DataError(msg)
        _same_certificate(s.meta, c.quantity, ref, cert, s.source)
        rows.append(dataclasses.replace(c, source=identity(ref)))
    return combine(rows, budget.coverage)


def _same_certificate(meta: dict[str, Any], quantity: str, ref: dict[str, Any],
                      cert: Certificate, source: str) -> None:
    """DataError when the data were corrected with a polygon certificate other than the
    one the certificate file lists for the polygon."""
    applied = meta.get("polygon_certificate") if quantity == "polygon" else None
    number = applied.get("certificate") if isinstance(applied, dict) else None
    if isinstance(number, str) and number and ref.get("certificate") \
            and number != ref["certificate"]:
        msg = (f"{source}: corrected with polygon certificate {number}, but {cert.source} "
               f"lists {ref['certificate']} for the polygon")
        raise DataError(msg)

"""An uncertainty budget (:class:`enctools.methods.budget.Budget`) as the document's table.

One row per contribution: quantity, source, type, distribution, value with its unit,
divisor, sensitivity c_i, standard uncertainty u_i and degrees of freedom nu_i; then
the combined u_c, nu_eff, k and U. The budget is in arcsec; u_i, u_c and U are shown in
the unit the report is read in (c_i in that unit per the value's unit).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from enctools.methods.budget import Budget
from enctools.report.display import label
from enctools.report.numbers import fmt, fmt_dof, fmt_u, significant
from enctools.units import factor

#: what the results say of their uncertainty when no budget is declared ("{gum}": the
#: reference number of the GUM in the document that says it)
TYPE_A = ("No uncertainty budget is declared for these inputs: the expanded uncertainty "
          "U = k u is the Type A evaluation the results carry (GUM 4.2 {gum}): the "
          "standard uncertainty u from the scatter of the repeated runs (s/√n per "
          "position) or as the method propagates it from the data, and k Student's t at "
          "95 % for the degrees of freedom the data state (the revolutions averaged), "
          "else 2 (about 95 % coverage for a normal distribution).")


def budget_table(budget: Budget, unit: str, table: Callable[..., dict[str, Any]]
                 ) -> dict[str, Any]:
    """The rows of ``budget`` with u_i [``unit``] (``table`` builds the table)."""
    k = factor("arcsec", unit)
    shown = label(unit)
    rows = []
    for c in budget.contributions:
        rows.append([c.name, c.source, c.kind, c.distribution,
                     f"{significant(c.value)} {c.unit}", fmt(c.divisor),
                     f"{significant(c.sensitivity * k)} {shown}/{c.unit}",
                     fmt_u(c.u_arcsec * k, unit), fmt_dof(c.dof, "∞")])
    return table(["quantity", "source", "type", "distribution", "value", "divisor", "c_i",
                  f"u_i [{shown}]", "ν_i"], rows, left=4)


def totals(budget: Budget, unit: str) -> list[list[str]]:
    """Rows (name, value) of u_c, nu_eff, k and U [``unit``]."""
    k = factor("arcsec", unit)
    shown = label(unit)
    return [["combined standard uncertainty u_c", f"{fmt_u(budget.u_c * k, unit)} {shown}"],
            ["effective degrees of freedom ν_eff (Welch–Satterthwaite)",
             fmt_dof(budget.nu_eff, "∞")],
            [f"coverage factor k ({budget.coverage:.0%} coverage)", fmt(budget.k, decimals=2)],
            ["expanded uncertainty U = k u_c", f"{fmt_u(budget.U * k, unit)} {shown}"]]

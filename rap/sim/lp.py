"""Small linear programs in equality form, ``min c.x`` subject to ``A x = b``, ``x >= 0``, solved by
HiGHS through ``highspy``.

Why not scipy's ``linprog(method="highs")``: it runs the same solver, but its wrapper (input
checks, option validation, building the result) took about 5 of the 7 milliseconds of one of
``rap.sim.statics``'s programs (3 x parts rows, 2 x contact points columns).

Options: the dual simplex, as scipy's ``method="highs"``; no presolve (it removes nothing from
those programs, every row an equation over several columns, and took a quarter of the time);
HiGHS's default tolerances (primal and dual feasibility 1e-7), so the model should be scaled to
order 1. One solver per thread is kept and reused: passing a model replaces the previous one and
its basis, so a solve does not depend on the ones before (checked: the same simplex iterations as a
fresh solver on every program of the 22-brick wall).

Cost: the simplex on the nonzeros of ``A`` (the dense matrix is read once to find them); for the
wall's programs (up to 66 rows, 200 columns) about a millisecond.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import highspy
import numpy as np

__all__ = ["LpResult", "solve_lp"]

_SOLVER = threading.local()
_INFEASIBLE = (highspy.HighsModelStatus.kInfeasible,
               highspy.HighsModelStatus.kModelError)  # as scipy: "the problem is infeasible"


@dataclass(frozen=True)
class LpResult:
    """``status``: "optimal", "infeasible", or HiGHS's description of another outcome (numerical
    trouble, a limit); ``x`` the solution when optimal, else None."""

    status: str
    x: np.ndarray | None = None


def _highs() -> highspy.Highs:
    h = getattr(_SOLVER, "highs", None)
    if h is None:
        h = _SOLVER.highs = highspy.Highs()
        h.setOptionValue("output_flag", False)
        h.setOptionValue("presolve", "off")
        h.setOptionValue("simplex_strategy", 1)  # dual
    return h


def solve_lp(a_eq: np.ndarray, b_eq: np.ndarray, cost: np.ndarray) -> LpResult:
    """``min cost.x`` subject to ``a_eq x = b_eq``, ``x >= 0``: ``a_eq`` dense [m, n] (its zeros
    are left out), ``b_eq`` [m], ``cost`` [n]. Thread-safe."""
    rows, cols = a_eq.shape
    col, row = np.nonzero(a_eq.T)  # column by column, rows sorted within a column
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = cols, rows
    lp.col_cost_ = np.asarray(cost, dtype=float)
    lp.col_lower_, lp.col_upper_ = np.zeros(cols), np.full(cols, highspy.kHighsInf)
    lp.row_lower_ = lp.row_upper_ = np.asarray(b_eq, dtype=float)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = np.searchsorted(col, np.arange(cols + 1)).astype(np.int32)
    lp.a_matrix_.index_ = row.astype(np.int32)
    lp.a_matrix_.value_ = a_eq.T[col, row]
    h = _highs()
    h.passModel(lp)
    h.run()
    status = h.getModelStatus()
    if status == highspy.HighsModelStatus.kOptimal:
        return LpResult("optimal", np.array(h.getSolution().col_value))
    if status in _INFEASIBLE:
        return LpResult("infeasible")
    return LpResult(h.modelStatusToString(status))

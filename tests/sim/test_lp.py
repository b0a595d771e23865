"""Equality-form linear programs through HiGHS (rap.sim.lp): known answers, and agreement with
scipy's linprog (the same solver behind its own wrapper) on random programs."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from rap.sim.lp import solve_lp

linprog = pytest.importorskip("scipy.optimize").linprog


def test_known_optimum():
    # min x0 + x2 with x0 + x1 = 1, x1 + x2 = 1, x >= 0: x1 = 1 alone, cost 0
    got = solve_lp(np.array([[1.0, 1, 0], [0, 1, 1]]), np.array([1.0, 1]), np.array([1.0, 0, 1]))
    assert got.status == "optimal"
    assert np.allclose(got.x, [0, 1, 0])


def test_infeasible():
    # x0 + x1 = -1 with x >= 0
    got = solve_lp(np.array([[1.0, 1]]), np.array([-1.0]), np.zeros(2))
    assert got.status == "infeasible" and got.x is None


def _random_program(rng):
    m, n = int(rng.integers(1, 8)), int(rng.integers(1, 16))
    a = rng.normal(size=(m, n)) * (rng.random((m, n)) < 0.6)
    return a, rng.normal(size=m), rng.random(n)


def test_agrees_with_scipy_linprog():
    rng = np.random.default_rng(7)
    statuses = set()
    for _ in range(200):
        a, b, c = _random_program(rng)
        got = solve_lp(a, b, c)
        ref = linprog(c, A_eq=a, b_eq=b, bounds=(0, None), method="highs")
        assert got.status == {0: "optimal", 2: "infeasible"}[ref.status]
        statuses.add(got.status)
        if ref.status == 0:
            assert c @ got.x == pytest.approx(ref.fun, abs=1e-7)
            assert np.allclose(a @ got.x, b, atol=1e-7) and (got.x >= -1e-9).all()
    assert statuses == {"optimal", "infeasible"}


def test_a_solve_does_not_depend_on_the_ones_before_or_on_the_thread():
    rng = np.random.default_rng(8)
    programs = [_random_program(rng) for _ in range(40)]
    first = [solve_lp(*p) for p in programs]
    again = [solve_lp(*p) for p in reversed(programs)][::-1]
    other: list = []
    worker = threading.Thread(target=lambda: other.extend(solve_lp(*p) for p in programs))
    worker.start()
    worker.join()
    for x, y, z in zip(first, again, other):
        assert x.status == y.status == z.status
        if x.x is not None:
            assert np.array_equal(x.x, y.x) and np.array_equal(x.x, z.x)

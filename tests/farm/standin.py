"""Test-only stand-ins with the contracts of the real layers (never imported by shipped code).

* ``operations(assembly)``: a small deterministic list of operations (each part moved into the rest
  along four directions); the farm does not care whether they are geometrically feasible.
  ``select_operations`` stands in for ``rap.enumerate.select_operations`` with them (a seeded
  subset of ``limit``), so farm tests know exactly which operations a run takes.
* ``render(assembly, op, size=64)``: a deterministic uint8 [2, size, size] image of the operation.
* ``simulate(assembly, op, params, rng)``: a fast deterministic fake of ``rap.sim.simulator.simulate``
  that sleeps ``params.time_limit_s`` milliseconds per operation (8 ms by default): the work's
  duration, never what orders a test's processes.
* ``held_simulate``: ``simulate``, except that a worker's operations after its first
  ``RAP_TEST_HOLD_AFTER`` (2 by default) wait while the file named by ``RAP_TEST_HOLD`` exists: a
  run is held mid-run, with rows committed, until the test removes the file, whatever the
  machine's speed (tests/farm/test_sigterm.py, test_writers.py, test_driver.py). A worker joined
  to a cluster gets both variables through its job's ``runtime_env`` (``hold_env``).
"""

from __future__ import annotations

import hashlib
import os
import time
from dataclasses import dataclass

import numpy as np

from rap.operation import Operation


@dataclass(frozen=True)
class FakeResult:
    successes: int
    trials: int
    score: float
    seconds: float


def operations(assembly, mode: str = "all") -> list[Operation]:
    ids = list(assembly.ids)
    out = []
    dirs = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]
    for i, pid in enumerate(ids):
        rest = frozenset(ids) - {pid}
        for d in dirs:
            out.append(Operation(frozenset({pid}), rest, d))
        if i + 1 < len(ids):  # a two-part subassembly too
            out.append(Operation(frozenset({pid}), frozenset({ids[i + 1]}), (0.6, 0.8)))
    gh = assembly.geometry_hash
    return sorted(out, key=lambda op: op.key(gh))


def select_operations(assembly, limit, root_seed, mode="all", directions_per_range=1, budget=None):
    from rap.enumerate import Selection
    from rap.seeds import derive_seed

    ops = operations(assembly, mode)
    gh = assembly.geometry_hash
    if limit is not None and limit < len(ops):
        ops = sorted(ops, key=lambda op: (derive_seed(root_seed, op.key(gh)), op.key(gh)))[:limit]
    return Selection(assembly, "all", len(ops), len(ops), lambda: iter(ops))


def render(assembly, op, size: int = 64, params=None):
    h = hashlib.sha256(op.key(assembly.geometry_hash).encode()).digest()
    rng = np.random.default_rng(int.from_bytes(h[:8], "little"))
    return rng.integers(0, 256, size=(2, size, size), dtype=np.uint8)


def simulate(assembly, op, params, rng):
    t = time.perf_counter()
    time.sleep(params.time_limit_s * 1e-3)
    p = 0.5 + 0.4 * op.direction[0]
    succ = int(rng.binomial(params.trials, min(max(p, 0.0), 1.0)))
    return FakeResult(succ, params.trials, succ / params.trials, time.perf_counter() - t)


_SIMULATED = [0]  # operations simulated by this process (a worker)


def held_simulate(assembly, op, params, rng):
    """``simulate``, held after a worker's ``$RAP_TEST_HOLD_AFTER`` operations (2 by default) while
    ``$RAP_TEST_HOLD`` exists (module doc)."""
    _SIMULATED[0] += 1
    hold = os.environ.get("RAP_TEST_HOLD", "")
    after = int(os.environ.get("RAP_TEST_HOLD_AFTER", "") or 2)
    while _SIMULATED[0] > after and hold and os.path.exists(hold):
        time.sleep(0.05)  # until the test removes the file
    return simulate(assembly, op, params, rng)


def hold_env() -> dict:
    """``RAP_TEST_HOLD`` and ``RAP_TEST_HOLD_AFTER`` of this process's environment, for a job's
    ``runtime_env={"env_vars": ...}``: the workers of a cluster joined by address do not inherit
    the driver's environment."""
    return {k: os.environ[k] for k in ("RAP_TEST_HOLD", "RAP_TEST_HOLD_AFTER") if k in os.environ}


def simulate_or_fail(assembly, op, params, rng):
    """``simulate``, except that every operation of an assembly named ``boom*`` raises."""
    if assembly.name.startswith("boom"):
        raise ValueError(f"simulated failure in {assembly.name}")
    return simulate(assembly, op, params, rng)


def failing_stream():
    """A selection's stream that fails (``rap.enumerate.Selection(..., stream=failing_stream)``)."""
    raise ValueError("enumeration exploded")

"""Test-only stand-ins with the contracts of the real layers (never imported by shipped code).

* ``operations(assembly)``: a small deterministic list of operations (each part moved into the rest
  along four directions) standing in for ``rap.enumerate.enumerate_operations`` until the geometry
  layer exists; the farm does not care whether they are geometrically feasible.
* ``render(assembly, op, size=64)``: a deterministic uint8 [2, size, size] image of the operation.
* ``simulate(assembly, op, params, rng)``: a fast deterministic fake of ``rap.sim.simulator.simulate``
  that sleeps ``params.time_limit_s`` milliseconds per operation (8 ms by default; ``slow_params``
  makes it 60 ms, so that a test can kill things mid-run in any process).
"""

from __future__ import annotations

import hashlib
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


def slow_params(trials: int = 100):
    """Simulator parameters whose fake simulation takes 60 ms per operation."""
    from rap.sim.params import SimParams

    return SimParams(trials=trials, time_limit_s=60.0)

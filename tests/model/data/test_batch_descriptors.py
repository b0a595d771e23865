"""Batched descriptors (rap.model.data.batch_descriptors) equal the exact per-operation ones
(rap.model.data.descriptors) on real assemblies, for exact and float directions, in any batching."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import rap
from rap.io import load_assembly
from rap.model.data.batch_descriptors import BatchDescriptors
from rap.model.data.descriptors import DESCRIPTORS, DescriptorContext, descriptors_for
from rap.operation import Operation
from rap.plan.graph import reachable
from rap.plan.problem import PlanningProblem
from rap.sim.params import SimParams

ROOT = Path(rap.__file__).resolve().parents[1]
CASES = [Path(rap.__file__).parent / "data" / "assemblies" / "hexagon.json",
         ROOT / "assemblies" / "unseen" / "tangram.json",
         ROOT / "assemblies" / "unseen" / "c-shapes-s100.json",  # non-convex parts
         ROOT / "assemblies" / "unseen" / "knobs-s101.json"]


def _ops(path: Path, limit: int = 400) -> tuple:
    problem = PlanningProblem(load_assembly(path), SimParams())
    graph = reachable(problem, 10**6)
    return problem.assembly, [op for c in graph.values() for op in c][:limit]


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_equal_to_exact_descriptors(path):
    assembly, ops = _ops(path)
    want = descriptors_for(DescriptorContext(assembly), ops)
    tables = BatchDescriptors(assembly)
    got = np.concatenate([tables.of(ops[i:i + 5]) for i in range(0, len(ops), 5)])
    assert got.shape == (len(ops), len(DESCRIPTORS)) and got.dtype == np.float32
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)
    np.testing.assert_array_equal(tables.of(ops), got)  # batching changes nothing


@pytest.mark.parametrize("path", CASES[:2], ids=lambda p: p.stem)
def test_float_directions_as_the_dataset_rows_carry_them(path):
    assembly, ops = _ops(path, 150)
    floats = [Operation(op.moving, op.fixed, op.direction) for op in ops]
    want = descriptors_for(DescriptorContext(assembly), floats)
    np.testing.assert_allclose(BatchDescriptors(assembly).of(floats), want, rtol=1e-5, atol=1e-6)


def test_blocked_operation_raises_and_empty_batch():
    assembly, ops = _ops(CASES[0], 1)
    op = ops[0]
    blocked = Operation(op.moving, op.fixed, (-op.direction[0], -op.direction[1]))
    tables = BatchDescriptors(assembly)
    with pytest.raises(ValueError, match="blocked"):
        DescriptorContext(assembly).descriptors(blocked)
    with pytest.raises(ValueError, match="blocked"):
        tables.of([blocked])
    assert tables.of([]).shape == (0, len(DESCRIPTORS))

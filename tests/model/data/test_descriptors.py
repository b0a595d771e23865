"""Geometric descriptors: exact removal ranges on known shapes, invariance under the motions that
leave the physics unchanged, and the same numbers in training, scoring and planning."""

from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction

import numpy as np
import pytest

from tests.model.model_fixtures import FAST_TRAIN, LEARN_MODEL
from rap.assembly_reader import assembly_from_json
from rap.model.data.descriptors import DESCRIPTORS, DescriptorContext, operation_descriptors
from rap.operation import Operation

D = {name: i for i, name in enumerate(DESCRIPTORS)}


def _assembly(parts: dict) -> object:
    return assembly_from_json({"parts": [{"id": k, "polygon": v} for k, v in parts.items()]})


def _slot(clearance: int, depth: int = 10) -> object:
    """A U-shaped holder (slot 4 + 2c wide, ``depth`` deep) and a 4-wide peg resting on the slot's
    floor, centred, its top flush with the holder's."""
    c = clearance
    w = 4 + 2 * c
    holder = [[0, 0], [10 + w, 0], [10 + w, depth + 2], [5 + w, depth + 2], [5 + w, 2],
              [5, 2], [5, depth + 2], [0, depth + 2]]
    peg = [[5 + c, 2], [9 + c, 2], [9 + c, depth + 2], [5 + c, depth + 2]]
    return _assembly({"holder": holder, "peg": peg})


def _insert(moving, fixed, direction) -> Operation:
    """The operation that brings ``moving`` home along ``direction`` (exact)."""
    dx, dy = direction
    n = math.hypot(dx, dy)
    return Operation(frozenset(moving), frozenset(fixed), (dx / n, dy / n),
                     (Fraction(dx), Fraction(dy)))


@pytest.mark.parametrize("clearance, width", [
    (0, 0.0),                        # a tight peg leaves one way only: straight up
    (1, 2 * math.atan2(1, 10)),      # its bottom corners pass the holder's top ones: 2 atan(c / depth)
    (3, 2 * math.atan2(3, 10)),
])
def test_the_removal_range_of_a_peg_in_a_slot(clearance, width):
    a = _slot(clearance)
    d = operation_descriptors(a, _insert({"peg"}, {"holder"}, (0, -1)))
    assert d[D["range_width_rad"]] == pytest.approx(width, abs=1e-6)
    assert d[D["single_direction"]] == float(clearance == 0)
    assert d[D["margin_rad"]] == pytest.approx(width / 2, abs=1e-6)  # straight up: the middle
    assert d[D["margin_fraction"]] == pytest.approx(1.0 if width else 0.0)
    assert d[D["moving_parts"]] == 1 and d[D["fixed_parts"]] == 1
    assert d[D["depth"]] == pytest.approx(1.0)  # the holder reaches the peg's top: all of it inside
    # contacts: the tight peg slides along both walls (2 x 10 of its 28 perimeter) and rests on
    # the floor (4); the loose one only rests on the floor
    sliding = 20 / 28 if clearance == 0 else 0.0
    assert d[D["sliding_contact"]] == pytest.approx(sliding, abs=1e-6)
    assert d[D["facing_contact"]] == pytest.approx(4 / 28, abs=1e-6)


def test_a_block_on_a_floor_leaves_by_half_the_circle_and_off_centre_directions_have_less_margin():
    a = _assembly({"floor": [[0, 0], [10, 0], [10, 2], [0, 2]],
                   "block": [[3, 2], [7, 2], [7, 5], [3, 5]]})
    up = operation_descriptors(a, _insert({"block"}, {"floor"}, (0, -1)))
    assert up[D["range_width_rad"]] == pytest.approx(math.pi)  # sliding off sideways included
    assert up[D["margin_rad"]] == pytest.approx(math.pi / 2)
    slant = operation_descriptors(a, _insert({"block"}, {"floor"}, (-1, -3)))  # removal (1, 3)
    assert slant[D["range_width_rad"]] == pytest.approx(math.pi)
    assert slant[D["margin_rad"]] == pytest.approx(math.atan2(3, 1))
    assert slant[D["margin_fraction"]] == pytest.approx(math.atan2(3, 1) / (math.pi / 2))


def test_a_float_direction_finds_the_same_range_as_the_exact_one():
    """Dataset rows keep the float unit vector only; a vertex direction must not fall beside it."""
    from rap.enumerate import enumerate_operations
    from rap.io import load_assembly
    import rap

    a = load_assembly(rap.__file__.rsplit("/", 1)[0] + "/data/assemblies/pentagons.json")
    ctx = DescriptorContext(a)
    ops = enumerate_operations(a, "all", directions_per_range=2)[:300]
    assert any(o.exact_direction is not None for o in ops)
    for op in ops:
        exact = ctx.descriptors(op)
        floats = ctx.descriptors(Operation(op.moving, op.fixed, op.direction))
        np.testing.assert_allclose(floats, exact, atol=1e-6)


def _transformed(op: Operation, m) -> Operation:
    (a, b), (c, d) = m
    ux, uy = op.direction
    ex, ey = op.exact_direction
    vx, vy = a * ux + b * uy, c * ux + d * uy
    n = math.hypot(vx, vy)
    return Operation(op.moving, op.fixed, (vx / n, vy / n), (a * ex + b * ey, c * ex + d * ey))


@pytest.mark.parametrize("name", ["hexagon", "rectilinear", "triangles"])
@pytest.mark.parametrize("m", [((-1, 0), (0, 1)), ((0, -1), (1, 0)), ((2, 0), (0, 2))],
                         ids=["mirror", "rotate90", "scale2"])
def test_descriptors_do_not_change_when_the_assembly_is_mirrored_rotated_or_scaled(name, m):
    from rap.assembly import assembly_to_json
    from rap.enumerate import enumerate_operations
    from rap.io import load_assembly
    import rap

    a = load_assembly(rap.__file__.rsplit("/", 1)[0] + f"/data/assemblies/{name}.json")
    data = assembly_to_json(a)
    (p, q), (r, s) = m
    for part in data["parts"]:
        ring = [[p * x + q * y + 7, r * x + s * y - 3] for x, y in part["polygon"]]
        part["polygon"] = ring
        part["holes"] = [[[p * x + q * y + 7, r * x + s * y - 3] for x, y in h]
                         for h in part.get("holes", [])]
    b = assembly_from_json(data)
    ctx_a, ctx_b = DescriptorContext(a), DescriptorContext(b)
    for op in enumerate_operations(a, "online", directions_per_range=2)[:60]:
        np.testing.assert_allclose(ctx_b.descriptors(_transformed(op, m)), ctx_a.descriptors(op),
                                   atol=1e-5)


def test_an_infeasible_operation_is_refused():
    a = _slot(0)
    with pytest.raises(ValueError, match="blocked"):
        operation_descriptors(a, _insert({"peg"}, {"holder"}, (1, 0)))  # in sideways


def test_dataset_descriptors_are_computed_once_and_match_the_planners(real_dataset, tmp_path,
                                                                      monkeypatch):
    from rap.io import load_assembly
    from rap.model.data.rows import RowStore
    import rap

    monkeypatch.setenv("RAP_CACHE_DIR", str(tmp_path / "cache"))
    store = RowStore(real_dataset)
    calls = []
    with_d = store.with_descriptors(DESCRIPTORS, lambda done, total: calls.append(total))
    assert with_d.descriptors.shape == (80, len(DESCRIPTORS)) and store.descriptors is None
    assert calls and len(list((tmp_path / "cache").glob("*.npy"))) == 1
    again = RowStore(real_dataset).with_descriptors(("depth", "range_width_rad"),
                                                    lambda *a: calls.append(a))
    assert len(calls) == 1  # from the cache, the columns asked for, in their order
    np.testing.assert_array_equal(again.descriptors, with_d.descriptors[:, [D["depth"],
                                                                            D["range_width_rad"]]])
    a = load_assembly(rap.__file__.rsplit("/", 1)[0] + "/data/assemblies/hexagon.json")
    ctx = DescriptorContext(a)
    i = int(np.flatnonzero(store.assembly == "hexagon")[0])
    op = Operation(frozenset(store.moving[i].split(",")), frozenset(store.fixed[i].split(",")),
                   tuple(store.direction[i]))
    np.testing.assert_allclose(with_d.descriptors[i], ctx.descriptors(op), atol=1e-6)


def test_a_descriptor_model_trains_scores_and_plans_with_both_engines(real_dataset, tmp_path,
                                                                      monkeypatch):
    from rap.io import load_assembly
    from rap.model.evaluation.cross_validation import score_checkpoint
    from rap.model.inference.torch_engine import TorchPredictor
    from rap.model.training.train import train
    from rap.model.inference.numpy_engine import load_numpy_predictor
    from rap.plan.problem import PlanningProblem
    from rap.model.inference.operations import OperationPredictor
    from rap.sim.params import SimParams
    import rap

    monkeypatch.setenv("RAP_CACHE_DIR", str(tmp_path / "cache"))
    cfg = replace(LEARN_MODEL, norm="batch", head="binomial", descriptors=DESCRIPTORS)
    res = train(real_dataset, holdout="rectilinear", model_config=cfg,
                config=replace(FAST_TRAIN, epochs=1))
    path = res.save(tmp_path / "desc.pt")
    pred = TorchPredictor.load(path)
    assert pred.descriptors == DESCRIPTORS
    images = np.zeros((3, 2, 64, 64), np.uint8)
    with pytest.raises(ValueError, match="descriptors"):
        pred.prob_high(images)  # the network needs them
    rows = score_checkpoint(path, real_dataset)
    assert rows[-1]["rows"] == 80 and 0.0 <= rows[-1]["accuracy"] <= 1.0
    a = load_assembly(rap.__file__.rsplit("/", 1)[0] + "/data/assemblies/hexagon.json")
    problem = PlanningProblem(a, SimParams(trials=10))
    ops = list(problem.candidates(problem.whole))[:6]
    fast = load_numpy_predictor(path)
    assert fast is not None and fast.descriptors == DESCRIPTORS
    torch_cnn, fast_cnn = OperationPredictor(pred), OperationPredictor(fast)
    expected = pred.expected_score(torch_cnn.images(problem, ops), torch_cnn.descriptors(problem, ops))
    np.testing.assert_allclose(torch_cnn.expected_score(problem, ops), expected, atol=1e-6)
    np.testing.assert_allclose(fast_cnn.expected_score(problem, ops), expected, atol=1e-5)


def test_images_only_checkpoints_are_written_as_before():
    from rap.model.network.cnn import ModelConfig, RobustnessCNN

    assert "descriptors" not in ModelConfig().to_dict()
    assert ModelConfig.from_dict(ModelConfig().to_dict()).descriptors == ()
    net = RobustnessCNN(ModelConfig())
    assert not any(k.startswith("descriptor") for k in net.state_dict())
    with pytest.raises(ValueError, match="descriptors"):
        ModelConfig(descriptors=("depth", "no-such"))


def test_train_command_takes_descriptors(real_dataset, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from rap.cli import app
    from rap.model.inference.torch_engine import TorchPredictor

    monkeypatch.setenv("RAP_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "d.pt"
    args = ["train", str(real_dataset), "--out", str(out), "--holdout", "rectilinear", "--epochs",
            "1", "--device", "cpu", "--batch-size", "32"]
    res = CliRunner().invoke(app, args + ["--descriptors", "all"])
    assert res.exit_code == 0, res.output
    assert "12 descriptors" in res.output
    assert TorchPredictor.load(out).descriptors == DESCRIPTORS  # bad names: test_cli_model.py

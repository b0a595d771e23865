"""Robot-cell constraints (rap.plan.cell.constraints, rap.plan.cell.rules) for every planning method.

Each plan is checked by independent checkers: the swept-area plan checker
(``rap.plan.report.validate.check_plan``), exact cone membership written here (``dot > 0`` and
``3 cross^2 <= dot^2`` is "within 30 degrees"), the base never on a moving side, one part per step,
and for gravity the pymunk settling simulation (``rap.sim.settling``) of every intermediate
assembly. Scores come from the stand-ins of ``tests.plan.standins`` (no simulator, no model).
"""

from __future__ import annotations

import json
from fractions import Fraction
from types import SimpleNamespace

import pytest

from rap.errors import ParameterError
from rap.io import load_assembly
from rap.plan.scoring.cache import ScoreCache
from rap.plan.cell.rules import blocked_by, constrained_candidates
from rap.plan.cell.constraints import SCORE_NOTE, CellConstraints, Cone
from rap.plan.methods import make_planner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStatus
from rap.plan.scoring.scorer import Scorer
from rap.plan.report.validate import check_plan
from rap.sim.params import SimParams

from tests.plan.cases import FRAMED_HOLE, ROOT, memory
from tests.plan.standins import HashSim, TableCnn, hash_score

PARAMS = SimParams(trials=10)
CELLS = ROOT / "assemblies" / "cells"
METHODS = ("search", "rap", "sim", "optimal", "random")

#: a peg with clearance in a slot open to the right: it leaves along (1, 0) within about 11 degrees
LOOSE_PEG = {"name": "loose-peg", "parts": [
    {"id": "block", "polygon": [[0, 0], [30, 0], [30, 10], [10, 10], [10, 20], [30, 20], [30, 30],
                                [0, 30]]},
    {"id": "peg", "polygon": [[10, 12], [30, 12], [30, 18], [10, 18]]},
]}


def cell(name):
    return load_assembly(CELLS / f"{name}.json")


def scorer():
    return Scorer(HashSim(), TableCnn(lambda op: 0.6 if hash_score(op) >= 0.8 else 0.3,
                                      hash_score), ScoreCache())


def plan(asm, method, stability_fn=None, **flags):
    c = CellConstraints.parse(**flags)
    problem = PlanningProblem(asm, PARAMS, constraints=c, stability_fn=stability_fn)
    options = {"samples": 5} if method == "random" else {}
    return make_planner(method, **options).solve(problem, scorer()), problem


def within_30(insertion, axis) -> bool:
    dot = insertion[0] * axis[0] + insertion[1] * axis[1]
    cross = axis[0] * insertion[1] - axis[1] * insertion[0]
    return dot > 0 and 3 * cross * cross <= dot * dot


def check(result, asm, base=None, linear=False):
    assert result.status is PlanStatus.FOUND, result.message
    assert check_plan(asm, result.steps) == []
    for s in result.steps:
        if base is not None and base in set(s.moving) | set(s.fixed):
            assert base in s.fixed
        if linear:
            assert len(s.moving) == 1
    assert CellConstraints.from_json(result.stats["constraints"]).base == base
    assert result.stats["score_note"] == SCORE_NOTE


# -- parsing -------------------------------------------------------------------------------------
@pytest.mark.parametrize("flags,parameter", [
    (dict(gravity="0,-1"), "gravity"),
    (dict(base="p", gravity="0,0"), "gravity"),
    (dict(base="p", gravity="down"), "gravity"),
    (dict(directions=["0,-1"]), "directions"),
    (dict(directions=["0,-1:181"]), "directions"),
    (dict(directions=["0,0:30"]), "directions"),
    (dict(directions=["0,-1:x"]), "directions"),
    (dict(directions=["1e999,0:30"]), "directions"),
    (dict(directions=["0,-1:30"] * 17), "directions"),
    (dict(base="p", gravity="0,-1", friction=-0.1), "friction"),
    (dict(friction=0.3), "friction"),
    (dict(base=""), "base"),
    (dict(base="p", layers=True), "layers"),
])
def test_bad_constraints_name_their_parameter(flags, parameter):
    with pytest.raises(ParameterError) as info:
        CellConstraints.parse(**flags)
    assert info.value.parameter == parameter and "\n" not in str(info.value)


def test_text_round_trips_and_words():
    c = CellConstraints.parse("plate", True, ["0,-1:30", "0.5,-1/3:12.5"], "0,-9.81", 0.4, True)
    assert c.active and c.directions[1].axis == (Fraction(1, 2), Fraction(-1, 3))
    doc = json.loads(json.dumps(c.to_json()))
    assert doc == {"base": "plate", "linear": True, "directions": ["0,-1:30", "0.5,-1/3:12.5"],
                   "gravity": "0,-9.81", "friction": 0.4, "layers": True}
    assert CellConstraints.from_json(doc) == c
    assert "within 30° of (0,-1)" in c.describe() and "plate fixed" in c.describe()
    assert not CellConstraints().active and CellConstraints.from_json({}) == CellConstraints()
    assert Cone.parse("1,0:90").text() == "1,0:90"
    with pytest.raises(ParameterError):
        CellConstraints.from_json({"bogus": 1})


def test_the_base_must_be_a_part():
    with pytest.raises(ParameterError) as info:
        PlanningProblem(cell("stack"), PARAMS, constraints=CellConstraints(base="nope"))
    assert info.value.parameter == "base" and "plate" in str(info.value)


# -- every method obeys them -------------------------------------------------------------------
@pytest.mark.parametrize("method", METHODS)
def test_every_method_keeps_the_base_still_and_moves_one_part(method):
    asm = cell("arch-centring")
    result, _ = plan(asm, method, base="centring", linear=True)
    check(result, asm, base="centring", linear=True)
    assert len(result.steps) == 3 and all("centring" in s.fixed for s in result.steps)


@pytest.mark.parametrize("method", METHODS)
def test_every_method_inserts_within_the_cone(method):
    asm = memory(LOOSE_PEG)
    # insertion towards the slot's bottom-left: the cone holds part of the peg's range only
    result, problem = plan(asm, method, base="block", directions=["-1,-0.5:30"])
    check(result, asm, base="block")
    (step,) = result.steps
    ins = step.operation.exact_direction
    assert within_30(ins, (-1, Fraction(-1, 2)))
    unconstrained = PlanningProblem(asm, PARAMS).candidates(problem.whole)
    assert all(op.exact_direction != ins for op in unconstrained)  # re-aimed, not the old middle
    assert step.direction == pytest.approx(_unit(ins))


def _unit(v):
    n = (float(v[0]) ** 2 + float(v[1]) ** 2) ** 0.5
    return (float(v[0]) / n, float(v[1]) / n)


def test_a_cone_holding_the_whole_range_keeps_the_operation():
    asm = memory(LOOSE_PEG)
    free = PlanningProblem(asm, PARAMS).candidates(frozenset(asm.ids))
    wide = PlanningProblem(asm, PARAMS, constraints=CellConstraints.parse(
        directions=["-1,0:90", "1,0:90"])).candidates(frozenset(asm.ids))
    assert wide == free


def test_the_side_peg_enters_from_the_side_only():
    asm = cell("side-peg")
    result, _ = plan(asm, "sim", base="base", directions=["0,-1:30"])
    assert result.status is PlanStatus.INFEASIBLE
    assert result.interlocked == ("base", "peg")
    assert result.message == ("no sequence satisfies the cell's constraints: the subassembly "
                              "{base,peg} cannot be built: every way to split it breaks "
                              "--directions 0,-1:30 (no insertion direction within 30° of (0,-1))")
    result, _ = plan(asm, "sim", base="base", directions=["-1,0:30"])
    check(result, asm, base="base")
    assert result.steps[0].operation.exact_direction == (-1, 0)


def test_a_real_interlock_is_named_as_before():
    result, _ = plan(memory(FRAMED_HOLE), "sim", base="side")
    assert result.status is PlanStatus.INFEASIBLE and result.interlocked == ("frame", "plug")
    assert "interlocked" in result.message and "constraints" not in result.message
    # one arm cannot move the interlocked pair as one: the constraint is named, not an interlock
    result, _ = plan(memory(FRAMED_HOLE), "sim", base="side", linear=True)
    assert result.interlocked == ("frame", "plug", "side")
    assert "every way to split it breaks one of --linear, --base side" in result.message


def test_linear_and_cone_together_name_both():
    asm = cell("stack")
    c = CellConstraints.parse(linear=True, directions=["-1,0:0"])
    problem = PlanningProblem(asm, PARAMS, constraints=c)
    # without --base, single blocks slide in along (-1, 0) exactly (a 0-degree cone: its axis)
    ops = problem.candidates(problem.whole)
    assert ops and all(len(op.moving) == 1 for op in ops)
    assert all(op.exact_direction == (-1, 0) for op in ops)
    stuck = PlanningProblem(asm, PARAMS, constraints=CellConstraints.parse(
        base="plate", linear=True, directions=["0,1:10"]))
    culprit, message = blocked_by(stuck, stuck.whole)
    assert culprit == stuck.whole and "--directions 0,1:10" in message and "\n" not in message


# -- gravity -------------------------------------------------------------------------------------
def below(assembly, ids, base, gravity, friction):
    """A stand-in stability check for the stack: each block rests on the one below it."""
    under = {"block1": "plate", "block2": "block1", "block3": "block2"}
    for p in sorted(ids):
        if p != base and under[p] not in ids:
            return SimpleNamespace(stable=False, reason=f"part {p} would fall")
    return SimpleNamespace(stable=True, reason="")


@pytest.mark.parametrize("method", METHODS)
def test_the_stack_is_built_bottom_up_under_gravity(method):
    asm = cell("stack")
    result, _ = plan(asm, method, stability_fn=below, base="plate", gravity="0,-1")
    check(result, asm, base="plate", linear=True)
    assert [s.moving for s in result.steps] == [("block1",), ("block2",), ("block3",)]


def test_gravity_blocks_name_the_part_that_falls():
    asm = cell("stack")
    result, _ = plan(asm, "sim", stability_fn=below, base="plate", gravity="0,-1",
                     directions=["0,1:30"])
    assert result.status is PlanStatus.INFEASIBLE
    assert "--directions 0,1:30" in result.message  # from below: nothing can go in

    def never(assembly, ids, base, gravity, friction):
        ok = ids == frozenset({base})
        return SimpleNamespace(stable=ok, reason="" if ok else "part block1 would tip")

    result, problem = plan(asm, "optimal", stability_fn=never, base="plate", gravity="0,-1")
    assert result.status is PlanStatus.INFEASIBLE
    assert "--gravity 0,-1 (part block1 would tip)" in result.message
    assert constrained_candidates(problem, frozenset({"block1", "block2"}),
                                  problem.constraints) == ()  # nothing to stand on


def test_stability_is_checked_once_per_subassembly():
    calls = []

    def counted(*args):
        calls.append(frozenset(args[1]))
        return below(*args)

    asm = cell("stack")
    result, _ = plan(asm, "optimal", stability_fn=counted, base="plate", gravity="0,-1")
    assert result.found and len(calls) == len(set(calls))


def test_the_arch_needs_its_centring():
    pytest.importorskip("highspy")
    result, _ = plan(cell("arch"), "sim", base="ground", gravity="0,-1")
    assert result.status is PlanStatus.INFEASIBLE and "--gravity 0,-1" in result.message
    asm = cell("arch-centring")
    result, _ = plan(asm, "sim", base="centring", gravity="0,-1")
    check(result, asm, base="centring", linear=True)
    _settles(asm, result, "centring")


def test_the_wall_stands_at_every_step():
    pytest.importorskip("highspy")
    asm = cell("brick-wall-22")
    result, _ = plan(asm, "sim", base="plate", gravity="0,-1")
    check(result, asm, base="plate", linear=True)
    for s in result.steps:  # gravity alone: every part rests on something below it
        ins = s.operation.exact_direction
        assert ins[1] <= 0  # from above or the side, never from below
    _settles(asm, result, "plate")


def _course(part: str) -> int:
    return int(part.split("_")[0][1:])  # c2_b3 -> 2


@pytest.mark.parametrize("method", ("search", "sim"))
def test_layers_build_the_wall_course_by_course(method):
    pytest.importorskip("highspy")
    asm = cell("brick-wall-22")
    result, _ = plan(asm, method, base="plate", gravity="0,-1", layers=True)
    check(result, asm, base="plate", linear=True)
    courses = [_course(s.moving[0]) for s in result.steps]
    assert courses == sorted(courses) and courses[0] == 0 and courses[-1] == 3
    assert "in layers" in CellConstraints.from_json(result.stats["constraints"]).describe()
    _settles(asm, result, "plate")


def test_layers_block_a_part_that_must_go_in_under_another():
    """A deck on a pillar and a block hung under the deck, which slides in from the side. With a
    stand-in stability (the block holds only once the deck is in) the deck goes first; layers
    would need the block, lying wholly below the deck, in before it: the line names --layers."""
    bridge = memory({"name": "bridge", "parts": [
        {"id": "ground", "polygon": [[0, 0], [40, 0], [40, 10], [0, 10]]},
        {"id": "left", "polygon": [[0, 10], [10, 10], [10, 30], [0, 30]]},
        {"id": "deck", "polygon": [[0, 30], [40, 30], [40, 40], [0, 40]]},
        {"id": "hang", "polygon": [[15, 20], [25, 20], [25, 30], [15, 30]]},
    ]})

    def held(assembly, ids, base, gravity, friction):  # the hanging block is glued to the deck
        ok = "hang" not in ids or "deck" in ids
        return SimpleNamespace(stable=ok, reason="" if ok else "part hang would fall")

    result, _ = plan(bridge, "sim", stability_fn=held, base="ground", gravity="0,-1")
    assert result.found
    order = [s.moving[0] for s in result.steps]
    assert order.index("deck") < order.index("hang")
    result, problem = plan(bridge, "sim", stability_fn=held, base="ground", gravity="0,-1",
                           layers=True)
    assert result.status is PlanStatus.INFEASIBLE
    assert "--layers" in result.message and "wholly below" in result.message, result.message


def _settles(asm, result, base):
    """Every intermediate assembly, simulated under gravity for 2 s, stays put (independent)."""
    from rap.sim.settling import settle

    built = {base}
    for s in result.steps:
        built |= set(s.moving)
        got = settle(asm, built, base, (0.0, -1.0), seconds=2.0)
        assert got.stable, (sorted(built), got.moved)


# -- the command, the service's request, the client -----------------------------------------------
def _cli(capsys, *args):
    from rap.cli import main

    try:
        main(["plan", *map(str, args)])
        code = 0
    except SystemExit as exc:
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("args,needle", [
    (("--gravity", "0,-1"), "--gravity 0,-1: needs a base part"),
    (("--base", "nope"), "--base nope: no such part in side-peg"),
    (("--directions", "0,-1"), "--directions '0,-1': expected DX,DY:DEG"),
    (("--base", "base", "--gravity", "0,-1", "--friction", "-1"), "--friction -1.0"),
])
def test_the_command_refuses_bad_constraints_in_one_line(capsys, args, needle):
    code, _, err = _cli(capsys, CELLS / "side-peg.json", "--method", "sim", "--no-cache", *args)
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, err


def test_the_command_plans_the_side_peg_from_the_side_only(capsys, tmp_path):
    src = CELLS / "side-peg.json"
    flags = ("--method", "sim", "--trials", "8", "--no-cache", "--workers", "1", "--base", "base")
    out = tmp_path / "plan.json"
    code, _, err = _cli(capsys, src, *flags, "--directions", "0,-1:30", "--out", out)
    assert code == 1 and len([x for x in err.strip().splitlines() if "error" in x]) == 1
    line = ("the subassembly {base,peg} cannot be built: every way to split it breaks "
            "--directions 0,-1:30")
    assert line in err
    doc = json.loads(out.read_text())  # the document names the block and the constraints too
    assert doc["feasible"] is False and line in doc["message"]
    assert doc["constraints"]["directions"] == ["0,-1:30"] and doc["score_note"] == SCORE_NOTE
    code, stdout, err = _cli(capsys, src, *flags, "--directions", "-1,0:30", "--linear",
                             "--out", out)
    assert code == 0, err
    doc = json.loads(out.read_text())
    (step,) = doc["steps"]
    assert step["moving"] == ["peg"] and step["insertion"] == pytest.approx([-1.0, 0.0])
    assert CellConstraints.from_json(doc["constraints"]).linear and doc["score_note"] == SCORE_NOTE
    assert "cell: base fixed in the fixture; one part per step" in " ".join(stdout.split())


def test_the_service_reads_and_checks_constraints():
    from rap.serve.api import BadRequest, parse_plan_request

    asm = json.loads((CELLS / "side-peg.json").read_text())
    body = {"assembly": asm, "method": "sim",
            "constraints": {"base": "base", "linear": True, "directions": ["-1,0:30"]}}
    *_, c = parse_plan_request(json.dumps(body).encode())
    assert c == CellConstraints.parse("base", True, ["-1,0:30"])
    *_, c = parse_plan_request(json.dumps({"assembly": asm}).encode())
    assert not c.active
    for bad, needle in [({"gravity": "0,-1"}, "constraints.gravity 0,-1: needs a base"),
                        ({"base": "x"}, "constraints.base x: no such part"),
                        ({"directions": "0,-1:30"}, "constraints.directions"),
                        ({"directions": [5]}, "constraints.directions"),
                        ({"linear": "yes"}, "constraints.linear"),
                        ({"base": "base", "gravity": "0,-1", "friction": "much"},
                         "constraints.friction"),
                        ({"up": 1}, "constraints 'up': unknown key"),
                        ([1], "constraints [1]")]:
        with pytest.raises(BadRequest) as info:
            parse_plan_request(json.dumps({"assembly": asm, "constraints": bad}).encode())
        assert info.value.status == 400 and needle in info.value.message, info.value.message


def test_the_client_sends_them():
    from rap.client import plan_body

    c = CellConstraints.parse("base", False, ["-1,0:30"])
    body = json.loads(plan_body(CELLS / "side-peg.json", "sim", constraints=c))
    assert body["constraints"] == c.to_json()
    assert "constraints" not in json.loads(plan_body(CELLS / "side-peg.json", "sim",
                                                     constraints=CellConstraints()))

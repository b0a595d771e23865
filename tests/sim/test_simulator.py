"""Simulator properties on the named fixtures (and the six reference assemblies when present)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rap.sim.params import SimParams
from rap.sim.simulator import SimResult, simulate
from rap.sim.trace import trace

from .fixtures import CASES, FUNNEL_PEG, TIGHT_PEG

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", sorted(CASES))
def test_noise_free_feasible_operations_always_succeed(name):
    a, o = CASES[name]
    res = simulate(a, o, SimParams(eta=0.0, trials=12), np.random.default_rng(0))
    assert res.successes == res.trials == 12
    assert res.score == 1.0


def _reference_operations():
    try:
        from rap.io import load_assembly
        from rap.geometry.ndbg import build_ndbg
        from rap.geometry.partitions import online_partitions
    except ImportError:
        return []
    ops = []
    for path in sorted((ROOT / "assemblies").glob("*.json")):
        a = load_assembly(path)
        for k, part in enumerate(online_partitions(build_ndbg(a), frozenset(a.ids))):
            ops.append(pytest.param(a, part.operation(), id=f"{a.name}-{k}"))
    return ops


_REF = _reference_operations()


@pytest.mark.skipif(not _REF, reason="assemblies/*.json or rap.geometry partitions not available")
@pytest.mark.parametrize("assembly,operation", _REF)
def test_noise_free_online_partitions_of_reference_assemblies_succeed(assembly, operation):
    res = simulate(assembly, operation, SimParams(eta=0.0, trials=4), np.random.default_rng(0))
    assert res.successes == res.trials


def test_funnel_scores_clearly_higher_than_tight_peg():
    p = SimParams()
    tight = simulate(*TIGHT_PEG, p, np.random.default_rng(11))
    funnel = simulate(*FUNNEL_PEG, p, np.random.default_rng(11))
    assert funnel.score >= tight.score + 0.25, (tight.score, funnel.score)
    assert 0.0 < tight.score < 1.0  # the default noise leaves the tight peg uncertain


def test_result_fields_and_score():
    """The funnel at seed 1: 7 of 10 trials, the same trials on every run (labels reproduce)."""
    res = simulate(*FUNNEL_PEG, SimParams(trials=10), np.random.default_rng(1))
    assert type(res) is SimResult and type(res.seconds) is float
    assert (res.successes, res.trials, res.score) == (7, 10, 0.7)
    assert res.outcomes == (1, 1, 1, 1, 1, 1, 0, 0, 1, 0)
    again = simulate(*FUNNEL_PEG, SimParams(trials=10), np.random.default_rng(1))
    assert (again.successes, again.outcomes, again.body_steps) == (7, res.outcomes, res.body_steps)


def test_rng_is_required():
    with pytest.raises(TypeError):
        simulate(*FUNNEL_PEG, SimParams(trials=2))


_CHILD = """
import importlib.util, json, sys
import numpy as np
spec = importlib.util.spec_from_file_location("fx", sys.argv[1])
fx = importlib.util.module_from_spec(spec); spec.loader.exec_module(fx)
from rap.sim.params import SimParams
from rap.sim.simulator import simulate
a, o = fx.CASES[sys.argv[2]]
r = simulate(a, o, SimParams(trials=int(sys.argv[3])), np.random.default_rng(int(sys.argv[4])))
print(json.dumps({"successes": r.successes, "outcomes": list(r.outcomes)}))
"""


def test_same_seed_same_outcomes_in_a_fresh_process():
    trials, seed = 30, 5
    here = simulate(*TIGHT_PEG, SimParams(trials=trials), np.random.default_rng(seed))
    out = subprocess.run([sys.executable, "-c", _CHILD, str(Path(__file__).with_name("fixtures.py")),
                          "tight_peg", str(trials), str(seed)],
                         capture_output=True, text=True, check=True, cwd=ROOT)
    there = json.loads(out.stdout)
    assert there["successes"] == here.successes
    assert tuple(there["outcomes"]) == here.outcomes


def test_different_seeds_give_different_trial_outcomes():
    p = SimParams(trials=30)
    outs = {simulate(*TIGHT_PEG, p, np.random.default_rng(s)).outcomes for s in range(3)}
    assert len(outs) > 1


@pytest.mark.parametrize("name", ["tight_peg", "funnel_peg", "corner"])
def test_retirement_keeps_single_contact_outcomes_and_saves_work(name):
    """On these fixtures (one contact at a time) retiring changes no outcome; where a body touches
    several pieces it may (see ``SimParams.fingerprint``), so retire=False has its own labels."""
    a, o = CASES[name]
    on = simulate(a, o, SimParams(trials=30, retire=True), np.random.default_rng(3))
    off = simulate(a, o, SimParams(trials=30, retire=False), np.random.default_rng(3))
    assert on.outcomes == off.outcomes
    assert on.score == off.score
    assert on.body_steps < off.body_steps  # retiring saved work


def test_hopeless_rules_do_not_change_outcomes_in_either_retirement_mode():
    p = SimParams(trials=30, far_off=0.05, stuck_s=0.5)  # aggressive: many trials decided early
    on = simulate(*TIGHT_PEG, p, np.random.default_rng(4))
    off = simulate(*TIGHT_PEG, p.with_(retire=False), np.random.default_rng(4))
    assert on.outcomes == off.outcomes


def test_trace_matches_simulate():
    p = SimParams(trials=12)
    res = simulate(*FUNNEL_PEG, p, np.random.default_rng(8))
    tr = trace(*FUNNEL_PEG, p, np.random.default_rng(8), k=3, every=5)
    assert tr.outcomes == res.outcomes[:3]
    assert tr.poses.shape[0] == 3 and tr.poses.shape[2] == 3
    assert not np.isnan(tr.poses).any()
    # every trial starts at the start offset, unrotated
    assert np.allclose(tr.poses[:, 0, :2], np.array(tr.start_offset), atol=1e-9)
    assert np.allclose(tr.poses[:, 0, 2], 0.0)
    # successful trials end near the goal
    for t in range(3):
        if tr.outcomes[t]:
            assert np.hypot(*tr.poses[t, -1, :2]) < 2.0


def _pymunk_objects_poly(made: list):
    """``new_poly`` as ``pymunk.Poly`` objects (what the simulator made before), kept in
    ``made``: the reference the raw ``cpShape*`` must equal bit for bit."""
    import pymunk
    from pymunk._chipmunk import lib

    def poly(body_ptr, vertices, radius):
        sh = pymunk.Poly(None, vertices, radius=radius)
        lib.cpShapeSetBody(sh._shape, body_ptr)
        made.append(sh)
        return sh._shape

    return poly


def test_raw_shapes_give_the_scene_pymunks_objects_give(monkeypatch):
    """A scene's shapes are made with Chipmunk's C calls (``new_poly``), not pymunk's objects:
    the same calls in the same order, so the same trials, poses and removals, bit for bit, on a
    contact-rich operation whose decided trials leave the space (and from displaced starts)."""
    import rap.sim.simulator as simulator
    from rap.sim.layouts import TrialLayout

    a, op = FUNNEL_PEG
    p = SimParams(trials=24)
    layouts = [TrialLayout({}, (0.02 * (k % 5 - 2), 0.01 * (k % 3 - 1), 0.01 * (k % 4 - 2)))
               for k in range(p.trials)]

    def run():
        plain = simulate(a, op, p, np.random.default_rng(5))
        scene = simulator.build_scene(a, op, p, layouts=layouts)
        info = simulator.run_trials(scene, p, np.random.default_rng(6), record=p.trials)
        return plain.outcomes, plain.body_steps, info.outcome.tolist(), info.recording[0]

    raw = run()
    made: list = []
    monkeypatch.setattr(simulator, "new_poly", _pymunk_objects_poly(made))
    ref = run()
    assert made, "the reference did not make pymunk's objects"
    assert raw[:3] == ref[:3] and 0 < sum(raw[0]) < p.trials  # some trials fail: contacts
    np.testing.assert_array_equal(raw[3], ref[3])


_DROP_SCRIPT = """
import gc, sys
import numpy as np
sys.path.insert(0, {root!r})
from tests.sim.fixtures import FUNNEL_PEG
from rap.sim.params import SimParams
from rap.sim.simulator import build_scene, remove_trial, run_trials
a, op = FUNNEL_PEG
p = SimParams(trials=8)
for order in range(6):
    scene = build_scene(a, op, p)
    if order % 3 == 1:
        run_trials(scene, p, np.random.default_rng(order))  # decided trials removed
    if order % 3 == 2:
        remove_trial(scene, 0)
    space, movers, shapes = scene.space, scene.movers, scene.fixed_shapes + scene.moving_shapes
    del scene
    for name in (["space", "movers", "shapes"] if order < 3 else ["shapes", "movers", "space"]):
        del globals()[name]
        gc.collect()
print("ok")
"""


def test_a_scene_dropped_in_any_order_frees_its_shapes_cleanly():
    """The raw shapes' lifetimes: a scene whose space, moving bodies and shapes are collected in
    either order (fresh, run, or with a trial removed) ends the process normally (a shape freed
    while still in a space, or a space touching a freed shape, would crash it)."""
    out = subprocess.run([sys.executable, "-c", _DROP_SCRIPT.format(root=str(ROOT))],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]

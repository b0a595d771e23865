"""The compiled control loop: pinned outcomes, Chipmunk's body order, the replay floor."""

from __future__ import annotations

import numpy as np
import pytest

from rap.sim import kernel
from rap.sim.params import SimParams
from rap.sim.simulator import build_scene, remove_trial, run_trials, simulate

from .fixtures import BESIDE, CASES, TIGHT_PEG

# (successes, body-steps) of 100 trials with rng seed 1, as computed by the numpy controller that
# the compiled loop replaced: the same outcomes, trial by trial, on every fixture.
PINNED = {
    "tight_peg": (31, 157210),
    "funnel_peg": (90, 82234),
    "beside": (99, 25103),
    "beside_down": (96, 67238),
    "multi": (94, 68482),
    "corner": (97, 38391),
    "corner_shallow": (96, 52295),
}


@pytest.mark.parametrize("name", sorted(PINNED))
def test_outcomes_pinned_to_the_numpy_controller(name):
    a, o = CASES[name]
    res = simulate(a, o, SimParams(), np.random.default_rng(1))
    assert (res.successes, res.body_steps) == PINNED[name]


def test_moving_bodies_come_first_and_the_static_body_last():
    scene = build_scene(*BESIDE, SimParams(trials=5))
    api = kernel.ChipmunkApi(scene.space, 6)
    ids = api.body_ids().tolist()
    assert ids[:5] == scene.mover_ids
    assert ids[5] == scene.space.static_body.id


def test_logged_commands_replay_the_same_run():
    p = SimParams(trials=20)
    steps = p.steps // p.control_substeps
    log = np.zeros((steps, p.trials + 1, 3))
    info = run_trials(build_scene(*TIGHT_PEG, p), p, np.random.default_rng(2), log=log)
    # replay on a fresh scene and compare the final poses of the trials still in the space
    ref_scene = build_scene(*TIGHT_PEG, p)
    run_trials(ref_scene, p, np.random.default_rng(2))
    scene = build_scene(*TIGHT_PEG, p)
    api = kernel.ChipmunkApi(scene.space, p.trials + 1)
    removals = {step // p.control_substeps: gone for step, gone in info.schedule}
    c = 0
    for stop in sorted(removals) + [info.steps_run // p.control_substeps]:
        kernel.replay_steps(api.ptrs, api.snum, api.sarr, log, c, stop, p.control_substeps, p.dt_s)
        c = stop
        for t in removals.get(stop, ()):
            remove_trial(scene, t)
    left = [t for t in range(p.trials) if scene.movers[t] in scene.space.bodies]
    assert left and left == [t for t in range(p.trials) if ref_scene.movers[t] in ref_scene.space.bodies]
    for t in left:
        assert scene.movers[t].position == ref_scene.movers[t].position

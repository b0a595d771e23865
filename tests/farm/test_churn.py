"""The farm under churn, forced deterministically: lost workers are not failing batches.

Faults are injected through ``SimPool._fetch``, the one place a task's result is fetched (the test
seam ``rap.farm.faults`` documents): the batch really ran, and its result is then lost as if its
actor had become unreachable or died. Nothing here waits on time.
"""

from __future__ import annotations

import dataclasses

import pytest
from ray.exceptions import ActorDiedError, ActorUnavailableError

from rap.dataset import open_dataset
from rap.io import load_assembly
from rap.sim.params import SimParams

from tests.farm import standin
from tests.farm.conftest import ASSEMBLIES, FAKE

pytestmark = pytest.mark.ray

TWO = (str(ASSEMBLIES / "grid.json"), str(ASSEMBLIES / "triangles.json"))


def losing(monkeypatch, error, times: int, key: str | None = None) -> list[int]:
    """Make ``SimPool._fetch`` lose a result ``times`` times in a row with ``error`` (the batch
    that holds ``key``, else any batch); returns the tally of injected losses."""
    from rap.farm.pool import SimPool

    real, lost = SimPool._fetch, [0]

    def fetch(self, ref):
        res = real(self, ref)
        if lost[0] < times and (key is None or key in res.table.column("key").to_pylist()):
            lost[0] += 1
            raise error()
        return res

    monkeypatch.setattr(SimPool, "_fetch", fetch)
    return lost


def unreachable():
    return ActorUnavailableError("injected: the actor is unreachable", None)


def cfg(out, **kw):
    from rap.farm.driver import LabelConfig

    base = dict(assemblies=TWO, out=str(out), trials=3, seed=11, max_ops_per_assembly=None,
                backend=FAKE, progress=False, flush_rows=4, workers=2, batch_size=2,
                selection_tasks=0)
    base.update(kw)
    return LabelConfig(**base)


def labels(out) -> list[dict]:
    return open_dataset(out).to_table().drop_columns(["node"]).sort_by("key").to_pylist()


def test_a_batch_whose_actor_is_unavailable_five_times_in_a_row_is_labelled(
        ray_local, fake_enum, monkeypatch, tmp_path):
    """One batch's actor is unreachable five times in a row while the other worker labels (the
    old rule, four losses fail the assembly, failed this run): the run completes, reports the
    churn, and its labels are those of an undisturbed run."""
    import rap.farm.driver as driver

    calm = tmp_path / "calm"
    driver.run_label(cfg(calm))
    victim = labels(calm)[len(labels(calm)) // 2]["key"]
    lost = losing(monkeypatch, unreachable, 5, key=victim)
    out = tmp_path / "churn"
    s = driver.run_label(cfg(out))
    assert lost[0] == 5
    assert not s.failed and s.labelled == s.total == len(labels(calm))
    assert (s.lost, s.resubmitted) == (5, 5) and s.redone_ops in (5, 10)  # batches of 1-2 ops
    assert labels(out) == labels(calm)
    text = driver.format_summary(s)
    assert (f"5 batches lost with their workers, 5 batches resubmitted ({s.redone_ops} "
            f"operations redone)") in text


def test_a_lost_batch_is_given_up_only_when_nothing_progresses(ray_local, monkeypatch):
    """With no batch completed for ``progress_timeout_s`` (0 here), a lost batch is failed and
    named; the other batches of the stream go on."""
    from rap.farm.pool import SimPool

    grid = load_assembly(ASSEMBLIES / "grid.json")
    params = SimParams(trials=2)
    ops = standin.operations(grid)[:6]
    losing(monkeypatch, unreachable, 1)
    with SimPool(1, backend=FAKE, batch_size=2, progress_timeout_s=0.0) as pool:
        got = list(pool.stream(SimPool.jobs(grid, ops, params, 5), params, images=False,
                               errors="collect"))
    failed = [r for r in got if r.error]
    assert len(failed) == 1 and sum(r.num_rows for r in got) == 4
    assert failed[0].error.startswith("a batch of grid was lost 1 times (ActorUnavailableError) "
                                      "and no batch has completed for 0 s")


def test_a_failing_simulation_is_retried_then_named(ray_local, tmp_path):
    """The simulator raises: the batch is sent again (another actor if there is one) up to three
    submissions, then its assembly fails with the simulator's one line; never a lost batch."""
    from rap.farm.pool import FarmError, SimPool

    boom = load_assembly(ASSEMBLIES / "grid.json")
    boom = dataclasses.replace(boom, name="boom")
    params = SimParams(trials=2)
    failing = dataclasses.replace(FAKE, simulate="tests.farm.standin:simulate_or_fail")
    with SimPool(2, backend=failing, batch_size=2) as pool:
        with pytest.raises(FarmError, match="simulation of a batch of boom failed: "
                                            "simulated failure in boom"):
            list(pool.stream(SimPool.jobs(boom, standin.operations(boom)[:2], params, 5), params))
        assert pool.stats["retried"] == 2 and pool.stats["lost"] == 0


def test_a_plan_whose_simulations_lose_their_actors_still_gets_its_answer(ray_local, monkeypatch):
    """The planning service's pool: five results in a row lost with their actors (died); the plan
    is found, and it is the plan of a run where nothing was lost."""
    from rap.farm.pool import SimPool
    from rap.serve.planning import PlanningService, PlanRequest
    from rap.plan.report.result import PlanStatus

    hexagon = load_assembly(ASSEMBLIES / "hexagon.json")
    sim = dataclasses.replace(FAKE, simulate="rap.sim.simulator:simulate")
    request = PlanRequest(hexagon, "sim", SimParams(trials=4), root_seed=5)
    with SimPool(2, backend=sim) as pool:
        calm = PlanningService(None, pool=pool).plan(request)
    lost = losing(monkeypatch, ActorDiedError, 5)
    with SimPool(2, backend=sim) as pool:
        churned = PlanningService(None, pool=pool).plan(request)
        assert pool.stats["lost"] == 5
    assert lost[0] == 5
    assert churned.status is calm.status is PlanStatus.FOUND
    assert churned.steps == calm.steps  # parts, directions and scores


def test_the_progress_timeout_has_one_default():
    """``label --progress-timeout``, ``LabelConfig`` and ``SimPool`` give up a lost batch after
    the same time without progress (``rap.farm.faults.PROGRESS_TIMEOUT_S``)."""
    import inspect

    from rap.commands.label import label
    from rap.farm.driver import LabelConfig
    from rap.farm.faults import PROGRESS_TIMEOUT_S
    from rap.farm.pool import SimPool

    flag = inspect.signature(label).parameters["progress_timeout"].default.default
    config = LabelConfig(assemblies=(), out="x").progress_timeout_s
    pool = inspect.signature(SimPool).parameters["progress_timeout_s"].default
    assert flag == config == pool == PROGRESS_TIMEOUT_S

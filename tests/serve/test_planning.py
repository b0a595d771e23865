"""The planning service on a small local Ray: concurrent requests, pooled simulation."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.ray

from rap.io import load_assembly  # noqa: E402
from rap.farm.actors import Backend  # noqa: E402
from rap.plan.report.result import PlanStatus  # noqa: E402
from rap.plan.report.validate import check_plan  # noqa: E402
from rap.sim.params import SimParams  # noqa: E402

from tests.farm.conftest import ASSEMBLIES  # noqa: E402

#: the real simulator; a stand-in renderer (the planner asks the pool for no images)
SIM = Backend(simulate="rap.sim.simulator:simulate", render="tests.farm.standin:render")
PARAMS = SimParams(trials=8)


def test_service_serves_two_concurrent_requests_on_the_pool(ray_local):
    import ray

    from rap.farm.pool import SimPool
    from rap.serve.planning import PlanRequest, start_service
    from rap.plan.planners.greedy import SimPlanner
    from rap.plan.problem import PlanningProblem
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.plan.scoring.scorer import Scorer

    hexagon = load_assembly(ASSEMBLIES / "hexagon.json")
    triangles = load_assembly(ASSEMBLIES / "triangles.json")
    pool = SimPool(2, backend=SIM)
    svc = start_service(None, pool=pool, max_concurrency=2)
    try:
        reqs = [PlanRequest(hexagon, "sim", PARAMS, root_seed=5),
                PlanRequest(triangles, "sim", PARAMS, root_seed=5, cold=True)]
        results = ray.get([svc.plan.remote(r) for r in reqs])
        assert ray.get(svc.peak_concurrency.remote()) == 2
    finally:
        ray.get(svc.close.remote())
        ray.kill(svc)
    for asm, res in zip((hexagon, triangles), results):
        assert res.status is PlanStatus.FOUND
        assert check_plan(asm, res.steps) == []
        assert res.stats["sim_run"] > 0
    # the pool's scores are the in-process scores: seeds depend on content only
    local = SimPlanner().solve(PlanningProblem(hexagon, PARAMS, 5), Scorer(LocalSimulator()))
    assert [s.score for s in local.steps] == [s.score for s in results[0].steps]
    assert local.robustness == results[0].robustness


def test_concurrent_callers_share_simulations_in_flight():
    """Two threads asking for overlapping operations: each operation is simulated once, and both
    get the same scores as a lone caller."""
    import threading
    import time

    from rap.serve.planning import SharedSimulations
    from rap.plan.scoring.cache import CachedScore
    from rap.plan.problem import PlanningProblem

    asm = load_assembly(ASSEMBLIES / "hexagon.json")
    problem = PlanningProblem(asm, PARAMS, root_seed=5)
    ops = list(problem.candidates(problem.whole))
    calls = []

    class Slow:
        def simulate_many(self, problem, batch):
            calls.append([problem.key(op) for op in batch])
            time.sleep(0.3)
            return [CachedScore(len(problem.key(op)) / 100, 1, 1) for op in batch]

    shared = SharedSimulations(Slow())
    out = {}
    threads = [threading.Thread(target=lambda n=n, part=part: out.__setitem__(
        n, shared.simulate_many(problem, part))) for n, part in enumerate((ops[:6], ops[3:]))]
    for t in threads:
        t.start()
        time.sleep(0.05)
    for t in threads:
        t.join()
    simulated = [k for batch in calls for k in batch]
    assert len(simulated) == len(set(simulated)) == len({problem.key(op) for op in ops})
    assert shared.shared == 3
    alone = Slow().simulate_many(problem, ops)
    assert out[0] + out[1][3:] == alone

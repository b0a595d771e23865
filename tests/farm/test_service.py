"""The planning service on a small local Ray: concurrent requests, pooled simulation."""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.ray

from rap.io import load_assembly  # noqa: E402
from rap.farm.actors import Backend  # noqa: E402
from rap.plan.result import PlanStatus  # noqa: E402
from rap.plan.validate import check_plan  # noqa: E402
from rap.sim.params import SimParams  # noqa: E402

from tests.farm.conftest import ASSEMBLIES  # noqa: E402

#: the real simulator; a stand-in renderer (the planner asks the pool for no images)
SIM = Backend(simulate="rap.sim.simulator:simulate", render="tests.farm.standin:render")
PARAMS = SimParams(trials=8)


def test_service_serves_two_concurrent_requests_on_the_pool(ray_local):
    import ray

    from rap.farm.pool import SimPool
    from rap.farm.service import PlanRequest, start_service
    from rap.plan.planners import SimPlanner
    from rap.plan.problem import PlanningProblem
    from rap.plan.scorers import LocalSimulator, Scorer

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

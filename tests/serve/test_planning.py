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
    get the same scores as a lone caller. The backend holds every batch until both callers have
    asked (each batch says when it has started): the second caller finds the first's operations
    in flight whatever the machine's speed."""
    import threading

    from rap.serve.planning import SharedSimulations
    from rap.plan.scoring.cache import CachedScore
    from rap.plan.problem import PlanningProblem

    asm = load_assembly(ASSEMBLIES / "hexagon.json")
    problem = PlanningProblem(asm, PARAMS, root_seed=5)
    ops = list(problem.candidates(problem.whole))
    assert len(ops) > 6  # the second caller has operations of its own, so simulates too

    class Held:
        """Scores by key; each batch says it has started (``started``), then waits for
        ``release``."""

        def __init__(self, released: bool = False):
            self.calls = []
            self.started = threading.Semaphore(0)
            self.release = threading.Event()
            if released:
                self.release.set()

        def simulate_many(self, problem, batch):
            self.calls.append([problem.key(op) for op in batch])
            self.started.release()
            assert self.release.wait(60), "never released"
            return [CachedScore(len(problem.key(op)) / 100, 1, 1) for op in batch]

    backend = Held()
    shared = SharedSimulations(backend)
    out = {}
    threads = [threading.Thread(target=lambda n=n, part=part: out.__setitem__(
        n, shared.simulate_many(problem, part))) for n, part in enumerate((ops[:6], ops[3:]))]
    threads[0].start()
    assert backend.started.acquire(timeout=60)  # the first caller's six are in flight
    threads[1].start()
    assert backend.started.acquire(timeout=60)  # the second has taken ops[3:6] as theirs
    backend.release.set()
    for t in threads:
        t.join(60)
        assert not t.is_alive()
    simulated = [k for batch in backend.calls for k in batch]
    assert len(simulated) == len(set(simulated)) == len({problem.key(op) for op in ops})
    assert shared.shared == 3
    alone = Held(released=True).simulate_many(problem, ops)
    assert out[0] + out[1][3:] == alone


class _SlowSimulator:
    """The real simulator, ``per_op_s`` seconds slower an operation: a search that would run
    longer than a small budget, whatever the machine."""

    def __init__(self, backend, per_op_s: float):
        self.backend, self.per_op_s = backend, per_op_s

    def simulate_many(self, problem, ops):
        import time

        time.sleep(self.per_op_s * len(ops))
        return self.backend.simulate_many(problem, ops)


def test_a_small_budget_answers_the_best_plan_found_in_time():
    """The HTTP service's path (``PlanningApp._plan``): the search is given the request's budget
    less the evaluation's share as its time limit, and stops simulating by time with a complete,
    valid plan and its bound, not "budget spent" (its hard budget: the answer's deadline, the
    budget and the 30 s grace). No time is asserted."""
    from rap.commands.plan import default_model_path
    from rap.geometry.families.simple import grid
    from rap.plan.scoring.scorer import Budget
    from rap.serve.budget import anytime_limits
    from rap.serve.planning import PlanningService, PlanRequest

    svc = PlanningService(default_model_path(), local_sim=True)
    svc.simulations.backend = _SlowSimulator(svc.simulations.backend, 0.2)
    asm = grid(4)  # its search simulates ~35 operations: ~7 s here, over the 3 s time limit
    options, hard_s = anytime_limits("search", {}, 4.0, 0.25, 30.0)
    result = svc.plan(PlanRequest(asm, "search", PARAMS, root_seed=5, planner_options=options,
                                  budget=Budget(max_simulations=2000, max_seconds=hard_s)))
    assert options == {"time_limit": 3.0}
    assert result.status is PlanStatus.FOUND, result.message
    assert result.stats["stopped"] == "time"
    assert len(result.steps) == len(asm) - 1 and check_plan(asm, result.steps) == []
    assert result.bound is not None and result.bound["robustness_upper"] >= result.robustness


def test_the_service_scores_with_the_clis_default_scorer():
    import inspect

    from rap.commands.plan import default_model_path
    from rap.model.inference.operations import OperationPredictor
    from rap.serve.api import ServeConfig
    from rap.serve.planning import PlanningService, start_service

    # the CLI loads OperationPredictor.load(model, engine="auto") (rap.commands.plan)
    for fn in (PlanningService.__init__, start_service):
        assert inspect.signature(fn).parameters["engine"].default == "auto"
    assert ServeConfig().engine == "auto"
    svc = PlanningService(default_model_path(), local_sim=True)
    assert type(svc.cnn) is type(OperationPredictor.load(default_model_path(), engine="auto"))
    assert type(svc.cnn).__name__ == "CascadeScorer"  # the shipped model's default scorer

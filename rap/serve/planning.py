"""The planning service: a Ray actor that holds the CNN and plans, simulating on the shared pool.

``PlanningService`` is a threaded actor (``max_concurrency`` requests at once). It loads the CNN
once, keeps one content-keyed ``ScoreCache`` (optionally on disk) and, whenever a planner needs the
simulator (RAP's fallback, the sim-only baseline, the optimum, the random baseline, the evaluation of
every returned sequence), sends the whole batch of operations to a ``SimPool``, the same pool of
simulation actors the labelling farm uses, which runs them in parallel on the cluster and returns
the scores in input order (``PoolSimulator``). The per-operation seed is the farm's
``label_seed``, so pooled, local and dataset scores of one operation are identical.

The actor itself asks for no CPU (``num_cpus=0``): it waits on the pool most of the time and runs
only the CNN's forward passes, so every CPU stays with the simulation workers.

    with connect(address) as rt:                       # rap.farm.runtime
        svc = start_service("model.pt")              # actor handle
        result = ray.get(svc.plan.remote(PlanRequest(assembly, "rap", params)))
        ray.get(svc.close.remote()); ray.kill(svc)

``run_plan(...)`` does exactly that for one request (what ``rap-farm plan --address`` calls).
Concurrent requests share the pool without waiting for each other: each request's batches are its
own tasks on the pool's actors, and ``SimPool`` keeps its bookkeeping thread-safe. An operation that
one request is already simulating is not simulated again for another: the second waits for the
first's result (``SharedSimulations``), which is the score it would have computed itself. The HTTP service
(``rap.serve.http_app``) holds one ``PlanningService`` object in its Ray Serve replica.
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import Any, Sequence

import ray
from ray.exceptions import RayTaskError

from rap.assembly import Assembly
from rap.errors import RapError
from rap.model.inference.operations import OperationPredictor
from rap.operation import Operation
from rap.plan.scoring.cache import CachedScore, ScoreCache
from rap.plan.scoring.local_simulator import LocalSimulator
from rap.plan.cell.constraints import CellConstraints
from rap.plan import plan
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanResult
from rap.plan.scoring.scorer import Budget, Scorer
from rap.seeds import DEFAULT_ROOT_SEED

from rap.farm.pool import SimPool
from rap.farm.runtime import connect

__all__ = ["PoolSimulator", "SharedSimulations", "PlanRequest", "PlanningService", "start_service",
           "run_plan", "run_plans"]


class PoolSimulator:
    """``SimBackend`` over a ``SimPool``: one parallel batch per call, results in input order.
    Safe to call from several threads at once (the pool's bookkeeping is locked, not its work)."""

    def __init__(self, pool: SimPool):
        self.pool = pool

    def simulate_many(self, problem: PlanningProblem, ops: Sequence[Operation]) -> list[CachedScore]:
        if not ops:
            return []
        res = self.pool.score(problem.assembly, list(ops), problem.params, problem.root_seed,
                              images=False)
        return [CachedScore(float(r.score), int(r.successes), int(r.trials)) for r in res]


class SharedSimulations:
    """``SimBackend`` wrapper for concurrent callers: operations (by ``problem.key``) in flight for
    one caller are awaited by the others instead of simulated twice. Errors reach every waiter."""

    def __init__(self, backend):
        self.backend = backend
        self._lock = threading.Lock()
        self._pending: dict[str, Future] = {}
        self.shared = 0  # operations answered by another caller's simulation

    def simulate_many(self, problem: PlanningProblem, ops: Sequence[Operation]) -> list[CachedScore]:
        keys = [problem.key(op) for op in ops]
        mine: dict[str, tuple[Operation, Future]] = {}
        theirs: dict[str, Future] = {}
        with self._lock:
            for k, op in zip(keys, ops):
                if k in mine or k in theirs:
                    continue
                if k in self._pending:
                    theirs[k] = self._pending[k]
                else:
                    mine[k] = (op, Future())
                    self._pending[k] = mine[k][1]
            self.shared += len(theirs)
        try:
            if mine:
                fresh = self.backend.simulate_many(problem, [op for op, _ in mine.values()])
                for (_, fut), res in zip(mine.values(), fresh):
                    fut.set_result(res)
        except BaseException as exc:
            for _, fut in mine.values():
                if not fut.done():
                    fut.set_exception(exc)
            raise
        finally:
            with self._lock:
                for k in mine:
                    self._pending.pop(k, None)
        return [(mine[k][1] if k in mine else theirs[k]).result() for k in keys]


EXECUTION_CANDIDATES = 3  # the search's plans a request's rollouts compare (``rap-farm plan``'s)


@dataclass(frozen=True)
class PlanRequest:
    """One planning job. ``cold``: plan with an empty score cache (for timings); the scores found
    are still added to the service's cache afterwards."""

    assembly: Assembly
    method: str = "rap"
    params: Any = None  # SimParams; None: the default parameters
    root_seed: int = DEFAULT_ROOT_SEED
    space: str = "online"
    samples: int = 50
    budget: Budget = field(default_factory=Budget)
    cold: bool = False
    planner_options: dict = field(default_factory=dict)  # make_planner's keyword options
    constraints: Any = None  # rap.plan.cell.constraints.CellConstraints; None: none
    rollouts: bool = False  # measure the plan by rollouts on the pool (and choose: the search)
    perturbed: bool = False  # with rollouts, the search: the choice also measures the best plan
    # on perturbed-start scores (``rap.plan.execution.ExecutionOptions.perturbed``)


class PlanningService:
    """Actor body (see module doc). ``pool``: a ``SimPool`` to share (None: make one with
    ``workers`` actors); ``local_sim``: simulate in this actor instead (tests, no pool);
    ``engine``: the CNN's scorer (``OperationPredictor.load``); ``"auto"`` by default, the CLI's:
    the default scorer (the gradient-boosted cascade beside the shipped model, the CNN only where it
    is unsure; ``rap.model.inference.cascade``), so that the service plans as ``rap-farm plan``
    does; ``"torch"`` or ``"cnn"``: the CNN alone (``rap-farm serve --engine``)."""

    def __init__(self, model_path: str | None = None, *, pool: SimPool | None = None,
                 workers: int | None = None, cache_path: str | None = None, device: str = "cpu",
                 local_sim: bool = False, engine: str = "auto"):
        self.cnn = (OperationPredictor.load(model_path, device=device, engine=engine) if model_path
                    else None)
        self.model_path = model_path
        self.pool = None
        if local_sim:
            backend = LocalSimulator()
        else:
            self.pool = pool if pool is not None else SimPool(workers)
            backend = PoolSimulator(self.pool)
        self.cache = ScoreCache(cache_path)
        self.simulations = SharedSimulations(backend)
        self.base = Scorer(self.simulations, self.cnn, self.cache)
        self._active = 0
        self._peak = 0
        self._count_lock = threading.Lock()

    def ready(self) -> dict:
        return {"model": self.model_path, "pool": self.pool.size if self.pool else 0,
                "cached_scores": len(self.cache)}

    def plan(self, request: PlanRequest) -> PlanResult:
        with self._count_lock:
            self._active += 1
            self._peak = max(self._peak, self._active)
        try:
            from rap.sim.params import SimParams

            params = request.params if request.params is not None else SimParams()
            problem = PlanningProblem(request.assembly, params, request.root_seed, request.space,
                                      constraints=request.constraints or CellConstraints())
            cache = ScoreCache() if request.cold else None
            scorer = self.base.fork(budget=request.budget, cache=cache)
            t = time.perf_counter()
            options, execution, runner = dict(request.planner_options), None, None
            if request.rollouts:
                execution, runner = self._execution(request.assembly, request.perturbed,
                                                    request.budget.max_seconds)
                if request.method == "search":
                    options.setdefault("alternatives", EXECUTION_CANDIDATES)
            result = plan(problem, request.method, scorer=scorer, samples=request.samples,
                          execution=execution, rollouts=runner, **options)
            if cache is not None:
                self.cache.put_many(cache.items())
            stats = dict(result.stats, service_seconds=time.perf_counter() - t)
            return result.with_(stats=stats)
        finally:
            with self._count_lock:
                self._active -= 1

    def _execution(self, assembly, perturbed: bool = False, seconds: float | None = None):
        """The rollouts of a request (``rap.plan.execution``): the shipped cell's errors and unit,
        the perturbed candidate when asked for, its simulations within ``eval_share`` of the
        request's ``seconds``; on the shared pool, or the local simulator (``local_sim``)."""
        from rap.serve.api import ServeConfig
        from rap.plan.execution import ExecutionOptions
        from rap.robot.cell import Cell

        cell = Cell()
        options = ExecutionOptions(errors=cell.error_model(),
                                   mm_per_unit=cell.unit_metres(assembly.units) * 1000.0,
                                   perturbed=perturbed, perturbed_seconds=None if seconds is None
                                   else ServeConfig.eval_share * seconds)
        if self.pool is None:
            return options, self.simulations.backend
        from rap.farm.rollouts import PoolRollouts

        return options, PoolRollouts(self.pool)

    def peak_concurrency(self) -> int:
        """The largest number of requests that were being served at the same time."""
        return self._peak

    def flush(self) -> str | None:
        p = self.cache.flush()
        return str(p) if p else None

    def close(self) -> None:
        """Write the cache and kill the pool's actors if this service made the pool."""
        self.cache.flush()
        if self.pool is not None:
            self.pool.shutdown()
            self.pool = None


_REMOTE_SERVICE = ray.remote(PlanningService)


def start_service(model_path: str | None = None, *, pool: SimPool | None = None,
                  workers: int | None = None, cache_path: str | None = None,
                  max_concurrency: int = 4, local_sim: bool = False, device: str = "cpu",
                  engine: str = "auto", ready_timeout_s: float = 300.0):
    """Start a ``PlanningService`` actor (Ray must be initialised) and wait until it is ready."""
    handle = _REMOTE_SERVICE.options(num_cpus=0, max_concurrency=max_concurrency).remote(
        model_path, pool=pool, workers=workers, cache_path=cache_path, device=device,
        local_sim=local_sim, engine=engine)
    ray.get(handle.ready.remote(), timeout=ready_timeout_s)
    return handle


def run_plans(requests: Sequence[PlanRequest], *, model_path: str | None = None,
              address: str | None = None, workers: int | None = None,
              cache_path: str | None = None, num_cpus: int | None = None) -> list[PlanResult]:
    """Start or join Ray (an already initialised Ray is used and left running), serve ``requests``
    concurrently on one planning service, then close the service and its pool."""
    with connect(address, num_cpus=num_cpus):
        svc = start_service(model_path, workers=workers, cache_path=cache_path,
                            max_concurrency=max(1, min(8, len(requests))))
        try:
            return ray.get([svc.plan.remote(r) for r in requests])
        except RayTaskError as exc:  # a one-line error raised inside the service: show it as such
            cause = getattr(exc, "cause", None)
            if isinstance(cause, RapError):
                raise cause from None
            raise
        finally:
            try:
                ray.get(svc.close.remote(), timeout=120)
            finally:
                ray.kill(svc)


def run_plan(request: PlanRequest, **kwargs) -> PlanResult:
    """``run_plans([request], **kwargs)[0]``: what ``rap-farm plan`` calls."""
    return run_plans([request], **kwargs)[0]

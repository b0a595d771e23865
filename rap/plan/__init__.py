"""Planning robust assembly sequences: one front door, ``plan``, over rooms of one idea each.

``plan(assembly, method="search", ...) -> PlanResult`` is how the CLI (``rap-farm plan``), the
planning service and the experiment plan: it builds the problem, the scorer and the planner and
solves, so the pipeline is assembled here only. The rooms:

* ``problem`` (the assembly, its operation space, content keys and seeds), ``graph`` (the AND/OR
  graph), ``dp`` (the dynamic programmes over it), ``interlocked`` (naming a minimal interlock),
  ``methods`` (the registry of planning methods);
* ``planners/``: the planner contract and the greedy, optimal and random planners, with options;
* ``search/``: the default planner, its options, its score state and its bound;
* ``scoring/``: the scorer, the local simulator, the score cache, the model's familiarity;
* ``cell/``: robot-cell constraints and their rules;
* ``report/``: the plan document, robot poses, reasons, intervals, the independent plan checker.

No ray; torch only where a model is loaded with the torch engine.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from rap.seeds import DEFAULT_ROOT_SEED

if TYPE_CHECKING:
    from rap.plan.report.result import PlanResult

__all__ = ["plan"]


def plan(assembly, method="search", *, model=None, constraints=None,
         seed: int = DEFAULT_ROOT_SEED, params=None, space: str = "online", simulator=None,
         cache=None, scorer=None, on_progress=None, execution=None, rollouts=None,
         **options) -> "PlanResult":
    """Plan a robust assembly sequence.

    Parameters
    ----------
    assembly : ``rap.assembly.Assembly``, a path (JSON, DXF or SVG: ``rap.io.load_assembly``) or a
        ``rap.plan.problem.PlanningProblem`` already built (then ``constraints``, ``seed``,
        ``params`` and ``space`` are the problem's).
    method : a method name of ``rap.plan.methods.METHODS`` (``search``, the default; ``rap``,
        ``sim``, ``optimal``, ``random``) or a planner object (``rap.plan.planners.base.Planner``).
    model : for methods that need one, a checkpoint path or a loaded CNN backend
        (``rap.model.inference.operations.OperationPredictor``); None: the shipped model.
    constraints : ``rap.plan.cell.constraints.CellConstraints`` of a robot cell (None: none).
    seed, params, space : the root seed of every simulation, the simulator's parameters
        (``rap.sim.params.SimParams``; None: the defaults, 100 trials) and the operation space.
    simulator : a simulator backend (``simulate_many``); None: simulations in this process.
    cache : a ``rap.plan.scoring.cache.ScoreCache`` (None: a fresh one in memory).
    scorer : a ready ``rap.plan.scoring.scorer.Scorer`` instead of ``model``, ``simulator`` and
        ``cache`` (the planning service passes one per request).
    on_progress : called with the scorer's counters before and after each batch.
    execution : ``rap.plan.execution.ExecutionOptions`` (None: none): the found plan's sequence
        success under the cell's errors, each step's success once reached, clearance and
        tolerance; with a planner that offers alternatives (the search's option
        ``alternatives``), the plan chosen among them by measured sequence success
        (``rap.plan.execution``; ``ExecutionOptions.perturbed``: the best plan on
        perturbed-start scores among them too).
    rollouts : a ``rap.execution.sequence.RolloutRunner`` (None: the simulator backend when it
        runs rollouts, else this process).
    **options : the method's options (``rap-farm plan --help``; e.g. ``simulations=0``).

    Returns
    -------
    ``rap.plan.report.result.PlanResult``: ``status`` (found, infeasible with the interlocked
    subassembly named, or budget spent), the steps in assembly order with their simulated scores,
    ``robustness`` (R, their product) and its interval, and the search's ``bound``.

    Raises
    ------
    ``rap.errors.InputError`` (a bad file or model path), ``rap.errors.ParameterError`` (an
    unknown method or an option out of range; it names the option).

    Example
    -------
    >>> from rap.plan import plan
    >>> from rap.sim.params import SimParams
    >>> result = plan("assemblies/rectilinear.json", simulations=0, params=SimParams(trials=10))
    >>> result.status.value, len(result.steps), 0.0 <= result.robustness <= 1.0
    ('found', 7, True)
    >>> plan("assemblies/rectilinear.json", "magic")
    Traceback (most recent call last):
    rap.errors.ParameterError: method 'magic': choose one of rap, sim, optimal, random, search
    """
    from rap.errors import InputError
    from rap.plan.cell.constraints import CellConstraints
    from rap.plan.methods import make_planner
    from rap.plan.planners.base import Planner
    from rap.plan.problem import PlanningProblem
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.scoring.scorer import Scorer
    from rap.sim.params import SimParams

    planner = method if isinstance(method, Planner) else make_planner(method, **options)
    if isinstance(assembly, PlanningProblem):
        problem = assembly
    else:
        if isinstance(assembly, (str, Path)):
            from rap.io import load_assembly

            assembly = load_assembly(assembly)
        problem = PlanningProblem(assembly, params or SimParams(), seed, space,
                                  constraints=constraints or CellConstraints())
    if scorer is not None:
        return _solve(planner, problem, scorer, execution, rollouts or simulator)
    needs = planner.options.needs_model
    if needs and (model is None or isinstance(model, (str, Path))):
        from rap.model.inference.operations import SHIPPED_MODEL, OperationPredictor

        path = Path(model) if model is not None else SHIPPED_MODEL
        if not path.is_file():
            raise InputError(f"{path}: no such checkpoint file (method {planner.name} needs a "
                             f"model)")
        model = OperationPredictor.load(path, engine="auto")
    own = simulator is None
    if own:
        from rap.plan.scoring.local_simulator import LocalSimulator

        simulator = LocalSimulator(processes=1)
    try:
        return _solve(planner, problem, Scorer(simulator, model if needs else None,
                                               cache if cache is not None else ScoreCache(),
                                               on_progress=on_progress),
                      execution, rollouts or simulator)
    finally:
        if own:
            simulator.close()


def _with_perturbed(problem, result, candidates, runner, execution, scorer=None) -> tuple:
    """``candidates`` and, unless it is one of them or the search's plan, the best plan on
    perturbed-start scores (``rap.plan.execution.perturbed_candidate``). The search's ``stats``
    get what became of it (its cost and fate, for the summary line): ``perturbed_simulated`` and
    ``perturbed_cached`` (operations simulated, found in the cache) and ``perturbed_outcome``
    (``offered``, ``duplicate``, ``none``: no sequence succeeds from perturbed starts, ``too
    large``: past ``PERTURBED_MAX_OPERATIONS``, or ``over budget``: past the scorer's budget of
    simulations or ``perturbed_seconds``). ``scorer``: its cache keeps the perturbed-start counts
    too; its budget's simulations left bound them."""
    from rap.plan.execution import perturbed_candidate

    def steps(p):
        return tuple((s.moving, s.fixed, s.direction) for s in p.steps)

    cache, left = None, None
    if scorer is not None:
        cache, limit = scorer.cache, scorer.budget.max_simulations
        left = None if limit is None else max(0, limit - scorer.stats.sim_run)
    found = perturbed_candidate(problem, result, runner, execution, cache, left)
    extra, simulated = found.plan, found.simulated
    outcome = ("offered" if extra is not None else "too large" if found.too_large else
               "over budget" if found.over_budget else "none")
    if extra is not None and steps(extra) in {steps(p) for p in (result, *candidates)}:
        extra, outcome = None, "duplicate"
    result.stats.update(perturbed_simulated=simulated, perturbed_cached=found.cached,
                        perturbed_outcome=outcome)
    return tuple(candidates) if extra is None else (*candidates, extra)


def _solve(planner, problem, scorer, execution, runner) -> "PlanResult":
    """``planner.solve``; with ``execution``, the plan measured (and chosen among the planner's
    alternatives) by rollouts (``rap.plan.execution``)."""
    if execution is None:
        return planner.solve(problem, scorer)
    from rap.plan.execution import execute_report
    from rap.plan.search.planner import SearchPlanner

    if isinstance(planner, SearchPlanner) and (planner.alternatives or execution.perturbed):
        outcome = planner.search(problem, scorer)  # it offers alternatives
        result, candidates = outcome.plan, outcome.alternatives
    else:
        result, candidates = planner.solve(problem, scorer), ()
    if not hasattr(runner, "run_rollouts"):
        runner = None
    if execution.perturbed and isinstance(planner, SearchPlanner) and result.found:
        candidates = _with_perturbed(problem, result, candidates, runner or scorer.simulator,
                                     execution, scorer)

    def finish(alt):
        from dataclasses import replace

        import math

        from rap.plan.planners.base import evaluate_steps
        from rap.plan.report.poses import annotate_plan

        steps = tuple(evaluate_steps(problem, scorer, alt.steps))
        return annotate_plan(replace(alt, steps=steps, robustness=math.prod(
            s.score for s in steps)), problem)

    return execute_report(problem, result, runner, execution, candidates, finish=finish)

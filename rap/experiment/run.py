"""The paper's planning experiment: RAP vs the sim-only baseline vs the optimum vs random.

For each assembly of a labelled dataset, with a CNN that has not seen that assembly (a checkpoint
``MODELS/holdout-NAME.pt``, else ``MODELS/holdout-family-FAMILY.pt`` of a model that has not seen
the assembly's family, else trained here with ``rap.model.training.train.train(dataset, holdout=NAME)`` and
saved as the former: ``holdout_model``), every method plans over the same operation space with the
dataset's simulator parameters and root seed (so the simulator's scores are the dataset's labels):

* each method's search runs with a COLD score cache (an empty ``ScoreCache``): no method looks fast
  because another one simulated its operations before; its wall time is ``PlanResult.seconds``;
* the returned sequence is then evaluated by the simulator (``robustness`` R); for ``random`` the
  figure is the mean R over ``samples`` random sequences.

With ``constraints`` (``rap.plan.cell.constraints.CellConstraints``: fixture, one arm, insertion cones,
gravity) every method plans under the same robot-cell constraints; the base must be a part of
every assembly.

Methods are named as in the report's tables: a method of ``rap.plan.methods`` with its options'
codes (``rap-k2-p90``, ``search-s200-o10``) or a preset (``rap-paper``): ``method_planner``.

``run_experiment`` takes what it works with as arguments: the simulator backend (the command
passes the Ray pool's ``PoolSimulator``), ``load_model`` (checkpoint -> CNN scorer),
``holdout`` (the hold-out model of an assembly) and ``planner`` (method name -> planner); tests
pass stand-ins. ``rap.experiment.report`` writes the report. No ray.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

from rap.errors import InputError, ParameterError
from rap.model.inference.operations import OperationPredictor
from rap.plan.scoring.cache import ScoreCache
from rap.plan.cell.constraints import CellConstraints
from rap.plan import plan
from rap.plan.methods import from_table_name, needs_model
from rap.plan.planners.base import Planner
from rap.plan.problem import PlanningProblem
from rap.plan.report.result import PlanStatus
from rap.plan.scoring.scorer import Scorer, SimBackend

__all__ = ["ExperimentRow", "holdout_model", "run_experiment", "method_planner",
           "check_held_out", "dataset_params", "EXPERIMENT_METHODS"]

EXPERIMENT_METHODS = ("random", "rap", "sim", "optimal")
#: the planner's statistics a row keeps (``ExperimentRow.extra``)
_EXTRA_STATS = ("exhaustive_sequences", "dp_evaluations", "operations", "dp_speedup", "cnn_ops",
                "fallback_candidates", "eval_simulations", "search", "search_simulations",
                "predicted_operations", "predicted_robustness")


def method_planner(method: str, samples: int = 50) -> Planner:
    """The planner of an experiment method name (``rap.plan.methods.from_table_name``): a method
    with its options' codes, e.g. ``rap-k2-p90`` (RAP's fallback simulates at most the 2
    candidates with the highest P(high); a candidate is high at P(high) >= 90 percent),
    ``rap-o10`` (best-first fallback, optimism 10 percent), ``rap-paper`` (the paper's rule),
    ``search-w2-s10`` (beam width 2, 10 simulations), ``search-s100-t97-o40`` (trust 97 percent,
    optimism 40 percent), ``search-b50`` (beam beyond 50 operations); ``random`` draws
    ``samples`` sequences. ``ParameterError`` (parameter ``method``) for a name it cannot read."""
    return from_table_name(method, samples=samples).build()


@dataclass
class ExperimentRow:
    assembly: str
    method: str
    robustness: float | None
    seconds: float
    eval_seconds: float
    status: str
    simulations: int = 0
    fallbacks: int | None = None
    decisions: int | None = None
    extra: dict = field(default_factory=dict)


def holdout_model(dataset: str | Path, name: str, models_dir: str | Path, epochs: int = 8,
                  log: Callable[[str], None] = print, family: str | None = None) -> Path:
    """``models_dir/holdout-NAME.pt``, else ``models_dir/holdout-family-FAMILY.pt``; trained on
    ``dataset`` minus ``name`` (saved as the former) when neither exists."""
    path = Path(models_dir) / f"holdout-{name}.pt"
    if path.is_file():
        return path
    if family:
        fam = Path(models_dir) / f"holdout-family-{family}.pt"
        if fam.is_file():
            return fam
    from rap.model.training.train import TrainConfig, train

    log(f"training a CNN without {name} ({epochs} epochs) -> {path}")
    res = train(dataset, holdout=name, config=TrainConfig(epochs=epochs))
    return res.save(path)


def dataset_params(dataset: str | Path):
    """(``SimParams``, root seed) of a labelled dataset, from its metadata."""
    from rap.dataset import read_meta
    from rap.sim.params import SimParams

    meta = read_meta(dataset)
    if meta is None:
        raise InputError(f"{dataset}: not a rap-farm dataset (no _rapfarm.json)")
    return SimParams.from_dict(dict(meta.params)), int(meta.root_seed)


def check_held_out(model: str | Path, assemblies: Sequence,
                   load_model: Callable = OperationPredictor.load):
    """The checkpoint ``model`` loaded (``load_model(model)``), to score with, or
    ``ParameterError`` (parameter ``model``) when it was trained on one of ``assemblies`` (same
    geometry hash, from the checkpoint's metadata): the experiment measures held-out assemblies
    only."""
    cnn = load_model(model)
    _refuse_seen(model, cnn.meta, assemblies)
    return cnn


def _refuse_seen(model: str | Path, meta: dict, assemblies: Sequence) -> None:
    trained = set()
    for a in meta.get("assemblies") or []:
        h = a.get("geometry_hash")
        trained.update(h if isinstance(h, list) else [h])
    seen = [a.name for a in assemblies if a.geometry_hash in trained]
    if seen:
        raise ParameterError("model", Path(model), f"trained on {', '.join(seen)}; the "
                             f"experiment needs assemblies the model has not seen")


def run_experiment(dataset: str | Path, assemblies: Sequence, *, sim_backend: SimBackend,
                   models_dir: str | Path = "models", epochs: int = 8, trials: int | None = None,
                   methods: Sequence[str] = EXPERIMENT_METHODS, samples: int = 50,
                   log: Callable[[str], None] = print, model: str | Path | None = None,
                   load_model: Callable = OperationPredictor.load,
                   holdout: Callable[..., Path] = holdout_model,
                   planner: Callable[[str, int], Planner] = method_planner,
                   constraints: CellConstraints | None = None,
                   loaded_model=None) -> list[ExperimentRow]:
    """Plan every assembly (``rap.assembly.Assembly`` objects named as in the dataset) with every
    method; see the module doc. ``trials`` overrides the dataset's trials per operation. With
    ``model``, that checkpoint scores every assembly (none of which it may have been trained on:
    ``check_held_out``) instead of one hold-out model per assembly, ``holdout(dataset, name,
    models_dir, epochs, log, family=...)``. ``load_model(path)`` reads a checkpoint;
    ``loaded_model``: ``model`` already read (``check_held_out``'s), not read again;
    ``planner(method, samples)`` makes a method's planner, once per plan; ``constraints``: the
    robot cell's (None: none; ``ParameterError`` for parameter ``base`` when an assembly lacks
    the base part)."""
    constraints = constraints or CellConstraints()
    for asm in assemblies:
        constraints.check(asm)
    params, root_seed = dataset_params(dataset)
    if trials is not None:
        params = params.with_(trials=int(trials))
    for method in methods:
        planner(method, samples)  # unknown names fail before any work
    any_cnn = any(needs_model(m) for m in methods)
    shared = None
    if model is not None and any_cnn:
        shared = loaded_model if loaded_model is not None else load_model(model)  # once
        _refuse_seen(model, shared.meta, assemblies)
    rows: list[ExperimentRow] = []
    for asm in assemblies:
        cnn, model_path = None, None
        if shared is not None:
            model_path, cnn = Path(model), shared
        elif any_cnn:
            model_path = holdout(dataset, asm.name, models_dir, epochs, log,
                                 family=getattr(asm, "family", None))
            cnn = load_model(model_path)
        for method in methods:
            rows.append(_plan_one(asm, method, params, root_seed, sim_backend, cnn, model_path,
                                  planner(method, samples), log, constraints))
    return rows


def _plan_one(asm, method: str, params, root_seed: int, sim_backend, cnn, model_path, planner,
              log, constraints: CellConstraints = CellConstraints()) -> ExperimentRow:
    """One assembly planned by one method with a cold score cache, as a row."""
    cnn_method = needs_model(method)
    problem = PlanningProblem(asm, params, root_seed, "online", constraints=constraints)
    scorer = Scorer(sim_backend, cnn if cnn_method else None, ScoreCache())  # cold
    if cnn_method:  # warm the CNN and renderer up once (imports, first-call costs)
        scorer.cnn.prob_high(problem, list(problem.candidates(problem.whole))[:1])
    res = plan(problem, planner, scorer=scorer)
    st = res.stats
    r = st.get("mean_robustness") if method == "random" else res.robustness
    row = ExperimentRow(asm.name, method, r, res.seconds, res.eval_seconds, res.status.value,
                        int(st.get("sim_run", 0)), st.get("fallbacks") if cnn_method else None,
                        st.get("decisions") if cnn_method else None,
                        {**{k: st[k] for k in _EXTRA_STATS if k in st},
                         "family": getattr(asm, "family", None),
                         "model": str(model_path) if cnn_method else None})
    log(f"{asm.name:14s} {method:8s} R={'-' if r is None else f'{r:.4f}'} "
        f"plan {res.seconds:.2f} s, {row.simulations} simulations"
        + (f", {row.fallbacks}/{row.decisions} fallbacks" if row.decisions is not None else ""))
    if res.status is not PlanStatus.FOUND:
        log(f"  {res.status.value}: {res.message}")
    return row

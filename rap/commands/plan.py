"""``rap-farm plan``: a robust assembly sequence for one assembly (RAP, sim, optimal or random).

Where the work happens:

* by default, in this process: the CNN runs without torch where it can (``rap.model.inference.numpy_engine``) and
  a batch of eight or more simulations is spread over forked worker processes on this machine
  (``--workers``, default every CPU; ``LocalSimulator``), so a small plan takes a few seconds;
* ``--address HOST:PORT|auto`` (or ``RAY_ADDRESS``, as in a Ray Job): on a Ray cluster, through a
  planning actor and a pool of simulation actors (``rap.serve.planning``);
* ``--server URL``: by a running planning service (``rap-farm serve``), over HTTP (``rap.client``);
  the table, ``--out`` and ``--picture`` are the same as for a local plan.

The same operation gets the same simulator seed everywhere, so scores do not depend on where they
were computed. Exit status 0 with a plan, 1 when the assembly is interlocked (no sequence of
one-step translations exists) or the cell's constraints (``--base``, ``--linear``,
``--directions``, ``--gravity``: ``rap.plan.cell.constraints``) block every sequence, 2 for invalid input (or a request the service refused), 3 when the
service fails.

``plan_command`` runs three steps: ``_check_request`` (the method, the space and every planner
option, by their declarations in ``rap.plan.methods``, which also make the options' flags),
``_plan_by_service`` or ``_plan_with_workers``, and ``_show`` (table, ``--out``, ``--picture``).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import typer

from rap.commands._cell_flags import (BASE, DIRECTIONS, FRICTION, GRAVITY, LAYERS, LINEAR,
                                     cell_constraints, check_cell)
from rap.commands._plan_output import print_result, write_outputs, write_plan_json
from rap.errors import EXIT_INFEASIBLE, InputError, ParameterError, RapError
from rap.plan.methods import (DEFAULT_METHOD, METHODS, RandomOptions, check_options,
                              method_options, needs_model, option_named)

__all__ = ["register", "plan_command", "InfeasiblePlan", "default_model_path", "print_result",
           "write_plan_json", "resolve_model"]


class InfeasiblePlan(RapError):
    """No assembly sequence exists (an interlocked subassembly). Exit status 1."""

    exit_code = EXIT_INFEASIBLE


def default_model_path() -> Path:
    """The model shipped with the package: ``rap/data/default_model.pt``."""
    from rap.model.inference.operations import SHIPPED_MODEL

    return SHIPPED_MODEL


def resolve_model(model: Path | None, method: str, echo) -> tuple[str | None, str]:
    """(checkpoint path or None, method to use). Without ``--model`` the shipped default model is
    used; when it is absent, say so and fall back to the simulator-only method."""
    if not needs_model(method):
        return None, method
    if model is not None:
        if not Path(model).is_file():
            raise InputError(f"--model {model}: no such checkpoint file")
        return str(model), method
    default = default_model_path()
    if default.is_file():
        return str(default), method
    echo(f"note: no --model given and no default model is shipped ({default} is missing; the "
         f"project trains it with `rap-farm train DATASET --out {default}`). Planning with "
         f"--method sim (simulator only) instead; pass --model PATH to use RAP's CNN.")
    return None, "sim"


def _check_suffix(path: Path | None, option: str, suffixes: tuple[str, ...]) -> None:
    if path is not None and Path(path).suffix.lower() not in suffixes:
        raise InputError(f"{option} {path}: must end in {' or '.join(suffixes)}")


def _local_workers(workers: int | None) -> int:
    if workers:
        return int(workers)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def _flag(name: str) -> str:
    """A parameter's flag: ``fallback_k`` -> ``--fallback-k``."""
    return "--" + name.replace("_", "-")


def _method_flag(name: str):
    """The flag of the planner option ``name``, as its method declares it (``rap.plan.methods``):
    range, help, and its default in words (the flag's own default is None: not given)."""
    method, opt = option_named(name)
    return typer.Option(None, _flag(name), min=opt.low, max=opt.high,
                        help=opt.help_text(method, _flag))


def _method_help() -> str:
    """``--method``'s help: the methods, the default first, and the summaries they declare."""
    names = [DEFAULT_METHOD] + [m for m in METHODS if m != DEFAULT_METHOD]
    notes = [f"{m}{', the default' if m == DEFAULT_METHOD else ''}: {METHODS[m].summary}"
             for m in names if METHODS[m].summary]
    return f"{' | '.join(names)} ({'; '.join(notes)})."


def plan_command(
    assembly: Path = typer.Argument(..., help="Assembly JSON file."),
    model: Path = typer.Option(None, "--model", help="CNN checkpoint [default: the shipped model]."),
    method: str = typer.Option(DEFAULT_METHOD, "--method", help=_method_help()),
    out: Path = typer.Option(None, "--out", "-o", help="Write the plan as JSON here."),
    csv: Path = typer.Option(None, "--csv", help="Write the plan's steps as CSV here (one row "
                             "a step: parts, insertion, poses, travel, units, score interval, "
                             "reason; README, Plan files)."),
    picture: Path = typer.Option(None, "--picture", help="Storyboard of the plan (.png or .svg)."),
    address: str = typer.Option(None, "--address", help="Plan on this Ray cluster (HOST:PORT or "
                                "auto; default $RAY_ADDRESS, else on this machine without Ray)."),
    server: str = typer.Option(None, "--server", help="Ask a running planning service "
                               "(rap-farm serve), e.g. http://127.0.0.1:8000."),
    token: str = typer.Option(None, "--token", help="Bearer token for --server [default: "
                              "$RAP_FARM_TOKEN]."),
    seed: int = typer.Option(None, "--seed", help="Root seed of the simulator's randomness."),
    trials: int = typer.Option(100, "--trials", min=1, help="Simulator trials per operation."),
    no_ray: bool = typer.Option(False, "--no-ray", help="Never use Ray, even with $RAY_ADDRESS "
                                "set (without --address this is the default)."),
    space: str = typer.Option("online", "--space",
                              help="online (one partition per NDBG cell, as RAP) | all."),
    cache: Path = typer.Option(None, "--cache", help="Score cache file [default: "
                               "~/.cache/rap-farm/scores.json or $RAP_CACHE]."),
    no_cache: bool = typer.Option(False, "--no-cache", help="Neither read nor write a cache file."),
    # the methods' options: declared, with their ranges and help, beside each planner
    samples: int = _method_flag("samples"),
    fallback_k: int = _method_flag("fallback_k"),  # RAP's fallback
    high_probability: float = _method_flag("high_probability"),
    fallback_optimism: float = _method_flag("fallback_optimism"),
    simulations: int = _method_flag("simulations"), trust: float = _method_flag("trust"),
    optimism: float = _method_flag("optimism"), upper: float = _method_flag("upper"),
    confidence: float = _method_flag("confidence"), gap: float = _method_flag("gap"),
    time_limit: float = _method_flag("time_limit"), beam_width: int = _method_flag("beam_width"),
    greedy_from: int = _method_flag("greedy_from"), improve: float = _method_flag("improve"),
    beam_from: int = _method_flag("beam_from"), window: int = _method_flag("window"),
    # the robot cell's constraints (rap.plan.cell.constraints; docs/PLANNING.md, Robot-cell constraints)
    base: str = BASE, linear: bool = LINEAR, directions: list[str] = DIRECTIONS,
    gravity: str = GRAVITY, friction: float = FRICTION, layers: bool = LAYERS,
    workers: int = typer.Option(None, "--workers", min=1, help="Simulation processes here, or "
                                "actors with --address [default: all CPUs]."),
    cell_file: Path = typer.Option(None, "--cell", help="Robot cell TOML: its [errors] and unit "
                                   "for the rollouts [default: the shipped cell]."),
    rollouts: bool = typer.Option(True, "--rollouts/--no-rollouts", help="Measure the plan's "
                                  "sequence success by rollouts under the cell's errors, and "
                                  "choose among the search's best plans by it."),
    candidates: int = typer.Option(3, "--candidates", min=0, max=20, help="Search: plans besides "
                                   "its best that the rollouts compare (0: the best only)."),
    perturbed: bool = typer.Option(False, "--perturbed-candidate", help="Search: the "
                                   "rollouts also compare the best plan on perturbed-start scores "
                                   "(every operation simulated once more; up to 3,000)."),
):
    """Plan a robust assembly sequence and print it (step, parts, direction, score, source)."""
    from rap.commands._console import console as make_console
    from rap.commands._progress import activity
    from rap.io import load_assembly
    from rap.seeds import DEFAULT_ROOT_SEED

    console, err = make_console(), make_console(stderr=True)
    options = dict(samples=samples, fallback_k=fallback_k, high_probability=high_probability,
                   fallback_optimism=fallback_optimism, beam_width=beam_width,
                   simulations=simulations, trust=trust, optimism=optimism, upper=upper,
                   confidence=confidence, gap=gap, time_limit=time_limit,
                   greedy_from=greedy_from, improve=improve, beam_from=beam_from,
                   window=window)  # None: not given
    _check_request(method, space, options, out, picture, err)
    cell = cell_constraints(base, linear, directions, gravity, friction, layers)
    _check_suffix(csv, "--csv", (".csv",))
    settings = dict(address=address, no_ray=no_ray, model=model, trials=trials, space=space,
                    cache=cache, no_cache=no_cache, workers=workers)
    if no_ray and address:
        raise InputError("--no-ray and --address exclude each other")
    if server is not None:
        _check_server_settings(settings, options)
    settings["constraints"] = cell
    settings["execution"] = (cell_file, candidates, perturbed) if rollouts else None
    if perturbed and (not rollouts or method != "search"):
        raise InputError("--perturbed-candidate: the search with rollouts only (not with "
                         "--no-rollouts or another method)")
    # a transient progress line on stderr (a terminal only) from here to the table
    with activity(f"planning {Path(assembly).name}", err) as progress:
        progress.update("reading the assembly")
        t0 = time.perf_counter()  # the wall time includes reading (a drawing: its import)
        asm = load_assembly(assembly)  # once: everything below takes ``asm``
        check_cell(cell, [asm])
        if server is not None:
            result, on_ray = _plan_by_service(assembly, asm, method, seed, options, server,
                                              token, progress, cell, rollouts,
                                              perturbed), False
            settings["cache"] = None
        else:
            root_seed = DEFAULT_ROOT_SEED if seed is None else int(seed)
            result, on_ray = _plan_with_workers(asm, method, root_seed, options, settings,
                                                progress, err)
    _show(console, err, asm, result, time.perf_counter() - t0, out=out, picture=picture,
          server=server, on_ray=on_ray, cache_path=settings["cache"], csv=csv)


def _check_request(method: str, space: str, options: dict, out, picture, err) -> None:
    """Step 1: the method, the operation space and every given planner option (checked by their
    declarations; a library's ``ParameterError`` becomes one line naming the flag), the output
    files' suffixes."""
    from rap.plan.problem import check_space

    try:
        method_options(method)
        check_space(space)
        check_options(**options)
    except ParameterError as exc:
        raise InputError(exc.for_name(_flag(exc.parameter))) from None
    if ((options["trust"] is not None or options["optimism"] or options["upper"]
         or options["gap"] is not None)
            and not options["simulations"]):
        err.print("[yellow]warning:[/] --trust, --optimism, --upper and --gap "
                  "choose what to simulate: without --simulations N they change nothing")
    _check_suffix(out, "--out", (".json",))
    _check_suffix(picture, "--picture", (".png", ".svg"))


def _check_server_settings(settings: dict, options: dict) -> None:
    """With ``--server``: refuse this machine's settings (the service plans with its own) and
    the planner options the service does not take (``--samples``)."""
    defaults = dict(address=None, no_ray=False, model=None, trials=100, space="online",
                    cache=None, no_cache=False)
    given = [(name, value, defaults[name]) for name, value in settings.items()
             if name != "workers"]
    given += [(o.name, options[o.name], o.default) for m in METHODS.values()
              for o in m.declared() if o.cli and not o.service]
    given += [("workers", settings["workers"], None)]
    given = [_flag(name) for name, value, default in given
             if value is not None and value != default]
    if given:
        raise InputError(f"--server and {given[0]} exclude each other (the service plans with "
                         f"its own settings: model, trials, cache, workers)")


def _plan_by_service(assembly: Path, asm, method: str, seed, options: dict, server: str, token,
                     console, constraints=None, rollouts: bool = True, perturbed=False):
    """Step 2, with ``--server``: the service plans; the method's options travel with the
    request. The client's errors name the parameter ``server``: here, the flag. ``console``:
    anything with ``status(text)`` (the command's progress ``Activity``, or a rich console)."""
    from rap.client import ServiceError, plan_body, post_plan
    from rap.commands._flags import flags
    from rap.plan.report.result import PlanResult

    sent = {o.name: options[o.name] for o in METHODS[method].declared() if o.service and o.cli}
    body = plan_body(assembly, method, seed, sent, constraints=constraints, loaded=asm,
                     rollouts=rollouts, perturbed=perturbed)
    with flags("server"), console.status(f"planning {asm.name} with {method} at {server} ..."):
        try:
            doc, details = post_plan(server, body, token=token or os.environ.get("RAP_FARM_TOKEN"))
        except ServiceError as exc:
            raise ServiceError(server, exc.reason, name="--server") from None
    try:
        result = PlanResult.from_json(doc, **details)
    except ValueError as exc:
        raise ServiceError(server, str(exc), name="--server") from None
    blocked = result.stats.get("blocked")  # a constraint's block, named by the service
    return result.with_(message=blocked) if isinstance(blocked, str) and not result.found \
        else result


def _plan_with_workers(asm, method: str, root_seed: int, options: dict, settings: dict, console,
                       err):
    """Step 2 otherwise: plan here (``_plan_here``) or on a Ray cluster (``--address``,
    ``$RAY_ADDRESS``), with the model (the shipped one by default) and the score cache.
    (result, whether on Ray); ``settings["cache"]`` becomes the cache file used, or None.
    ``console``: anything with ``status(text)``; the command passes its progress ``Activity``."""
    from rap.plan.scoring.cache import default_cache_path
    from rap.sim.params import SimParams

    params = SimParams(trials=settings["trials"])
    model_path, method = resolve_model(settings["model"], method, lambda s: err.print(s))
    cache_path = None if settings["no_cache"] else (settings["cache"] or default_cache_path())
    settings["cache"] = cache_path
    address = settings["address"]
    address = None if settings["no_ray"] else (address or os.environ.get("RAY_ADDRESS") or None)
    space, workers = settings["space"], settings["workers"]
    if address is None:  # ``console``: the command's progress Activity, told what happens
        return _plan_here(asm, method, params, root_seed, space, model_path, cache_path,
                          _local_workers(workers), err, options,
                          progress=console if hasattr(console, "scorer_progress") else None,
                          constraints=settings.get("constraints"),
                          execution=settings.get("execution")), False
    import rap.serve.planning as service

    if model_path is not None:
        _familiarity(asm, _load_cnn(model_path), space, err)
    planner_options = {k: v for k, v in options.items() if k != "samples"}
    req = service.PlanRequest(asm, method, params, root_seed, space,
                              options["samples"] or RandomOptions().samples,
                              planner_options=planner_options, constraints=settings.get("constraints"),
                              rollouts=settings.get("execution") is not None,
                              perturbed=bool((settings.get("execution") or (0, 0, 0))[2]))
    with console.status(f"planning {asm.name} with {method} on Ray at {address} ..."):
        result = service.run_plan(req, model_path=model_path, address=address, workers=workers,
                                  cache_path=str(cache_path) if cache_path else None)
    return result, True


def _show(console, err, asm, result, wall: float, *, out, picture, server, on_ray,
          cache_path, csv=None) -> None:
    """Step 3: the plan's table, ``--out``, ``--csv`` and ``--picture``; ``InfeasiblePlan``
    (exit 1) without a plan (the ``--out`` document still written for an interlocked assembly;
    no ``--csv``: it has no steps)."""
    from rap.plan.report.result import PlanStatus

    if result.status is PlanStatus.INFEASIBLE:
        if out is not None:
            write_plan_json(result, out)
            err.print(f"wrote {out}")
        raise InfeasiblePlan(result.message)
    if result.status is not PlanStatus.FOUND:
        raise InfeasiblePlan(f"no plan: {result.message}")
    print_result(console, result, wall_s=wall, ray=on_ray)
    if server is not None:
        console.print(f"planned by the service at {server}", style="dim")
    write_outputs(console, asm, result, out=out, csv=csv, picture=picture)
    if cache_path is not None:
        console.print(f"score cache: {cache_path}", style="dim")


def _load_cnn(model_path: str):
    from rap.model.inference.operations import OperationPredictor

    return OperationPredictor.load(model_path, engine="auto")


def _plan_here(asm, method, params, root_seed, space, model_path, cache_path, workers, err,
               options: dict | None = None, constraints=None, progress=None, execution=None):
    """Plan in this process; simulation batches over ``workers`` forked processes; ``options``:
    ``make_planner``'s (None: the default); ``progress``: an ``Activity`` told what happens;
    ``execution``: the rollouts' ``(cell file, candidates, perturbed)`` (``commands._rollouts``)."""
    from rap.commands._progress import activity
    from rap.plan.scoring.cache import ScoreCache
    from rap.plan.methods import make_planner
    from rap.plan.cell.constraints import CellConstraints
    from rap.plan.problem import PlanningProblem
    from rap.plan import plan
    from rap.plan.scoring.local_simulator import LocalSimulator
    from rap.commands._rollouts import execution_options

    # simulation workers first: they load the simulator while this process loads the model,
    # renders and scores (see LocalSimulator's prestart)
    progress = progress or activity("", enabled=False)  # an Activity told what happens
    progress.update("starting simulation workers" + (", loading the model" * bool(model_path)))
    sim = LocalSimulator(processes=workers, prestart=True)
    cache_obj = None
    try:
        # one part: no operation to score, so no model to load (a second or more)
        cnn = _load_cnn(model_path) if model_path and len(asm.parts) > 1 else None
        problem = PlanningProblem(asm, params, root_seed, space,
                                  constraints=constraints or CellConstraints())
        if cnn is not None:
            _familiarity(asm, cnn, space, err, problem=problem)
            if sim.prestarted:
                cnn.cores_busy = sim.loading
        cache_obj = ScoreCache(cache_path)
        ex_options, options = execution_options(execution, asm, method, options or {})
        planner = make_planner(method, **options)  # a bad option fails before the NDBG
        progress.update("building the NDBG")
        problem.candidates(problem.whole)  # builds it (once, kept by the problem)
        progress.update("NDBG built; planning")
        result = plan(problem, planner, model=cnn, simulator=sim, cache=cache_obj,
                      on_progress=progress.scorer_progress, execution=ex_options)
    finally:
        sim.close()
        if cache_obj is not None:  # also when interrupted: a rerun starts from the scores found
            cache_obj.flush()
    return result


def _familiarity(asm, cnn, space: str, err, problem=None) -> None:
    """Warn when ``asm`` is far from what the model was trained on (checkpoint metadata)."""
    try:
        from rap.plan.problem import PlanningProblem
        from rap.plan.scoring.familiarity import familiarity_operations, model_familiarity
        from rap.sim.params import SimParams

        problem = problem or PlanningProblem(asm, SimParams(), space=space)
        ops = familiarity_operations(problem)  # none: every operation is free
        notes = model_familiarity(cnn.meta, asm.geometry_hash,
                                  cnn.images(problem, ops) if ops else ())
    except RapError:
        raise
    except Exception as exc:  # a failed check must not stop planning
        notes = [f"could not compare the assembly with the model's training data ({exc})"]
    for n in notes:
        err.print(f"[yellow]warning:[/] {n}")


def register(app: typer.Typer) -> None:
    app.command("plan")(plan_command)

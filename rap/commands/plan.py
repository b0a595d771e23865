"""``rap-farm plan``: a robust assembly sequence for one assembly (RAP, sim, optimal or random).

Where the work happens:

* by default, in this process: the CNN runs without torch where it can (``rap.model.fastcnn``) and
  a batch of eight or more simulations is spread over forked worker processes on this machine
  (``--workers``, default every CPU; ``LocalSimulator``), so a small plan takes a few seconds;
* ``--address HOST:PORT|auto`` (or ``RAY_ADDRESS``, as in a Ray Job): on a Ray cluster, through a
  planning actor and a pool of simulation actors (``rap.farm.service``);
* ``--server URL``: by a running planning service (``rap-farm serve``), over HTTP (``rap.client``);
  the table, ``--out`` and ``--picture`` are the same as for a local plan.

The same operation gets the same simulator seed everywhere, so scores do not depend on where they
were computed. Exit status 0 with a plan, 1 when the assembly is interlocked (no sequence of
one-step translations exists), 2 for invalid input (or a request the service refused), 3 when the
service fails.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from pathlib import Path

import typer

from rap.errors import EXIT_INFEASIBLE, InputError, RapError
from rap.plan.methods import METHODS  # rap, sim, optimal, random, search

__all__ = ["register", "plan_command", "InfeasiblePlan", "default_model_path", "print_result",
           "write_plan_json", "resolve_model"]

CNN_METHODS = ("rap", "search")  # the methods that need a model


class InfeasiblePlan(RapError):
    """No assembly sequence exists (an interlocked subassembly). Exit status 1."""

    exit_code = EXIT_INFEASIBLE


def default_model_path() -> Path:
    """The model shipped with the package: ``rap/data/default_model.pt``."""
    import rap

    return Path(rap.__file__).resolve().parent / "data" / "default_model.pt"


def resolve_model(model: Path | None, method: str, echo) -> tuple[str | None, str]:
    """(checkpoint path or None, method to use). Without ``--model`` the shipped default model is
    used; when it is absent, say so and fall back to the simulator-only method."""
    if method not in CNN_METHODS:
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


def write_plan_json(result, path: Path) -> Path:
    """Write ``result.to_json()`` (the one serialiser of a plan, also the planning service's answer)
    atomically: temporary file + rename."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".json", dir=path.parent)
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(result.to_json(), fh, indent=2)
            fh.write("\n")
        os.replace(tmp, path)
    except OSError as exc:
        raise InputError(f"--out {path}: cannot write ({exc.strerror or exc})") from None
    return path


def print_result(console, result, *, wall_s: float | None = None, title: str | None = None,
                 ray: bool = False) -> None:
    """The sequence as a rich table, R and timings."""
    from rich.table import Table

    from rap.plan.result import PlanStatus

    if result.status is not PlanStatus.FOUND:
        console.print(f"[bold red]{result.status.value}[/]: {result.message}")
        return
    table = Table(title=title or f"{result.assembly}: {result.method} plan "
                                 f"({len(result.steps)} steps, assembly order)")
    for col, kw in (("step", {"justify": "right"}), ("moving", {"overflow": "fold"}), ("fixed", {"overflow": "fold"}),
                    ("direction", {"no_wrap": True}), ("score", {"justify": "right"}), ("chosen by", {}),
                    ("P(high)", {"justify": "right"})):
        table.add_column(col, **kw)
    for i, s in enumerate(result.steps, 1):
        bad = s.score is not None and s.score < 0.95
        score = "?" if s.score is None else f"{s.score:.3f}"
        table.add_row(str(i), ",".join(s.moving), ",".join(s.fixed),
                      f"({s.direction[0] + 0.0:+.3f},{s.direction[1] + 0.0:+.3f})",
                      f"[red]{score}[/]" if bad else score, s.source,
                      "" if s.confidence is None else f"{s.confidence:.3f}")
    console.print(table)
    st = result.stats
    line = f"robustness R = {result.robustness:.4f} (product of the simulator's step scores)"
    if result.method == "random" and "mean_robustness" in st:
        line += (f"; mean over {st['samples']} random sequences = {st['mean_robustness']:.4f} "
                 f"(shown: the sample closest to the mean)")
    console.print(line)
    parts = [f"planning {result.seconds:.2f} s", f"evaluation {result.eval_seconds:.2f} s"]
    if wall_s is not None:
        parts.append(f"wall {wall_s:.2f} s" + (" (Ray start-up included)" if ray else ""))
    if st.get("service_seconds") is not None and not ray:
        parts.append(f"service {st['service_seconds']:.2f} s")
    console.print("time: " + ", ".join(parts))
    facts = [f"{st.get('sim_run', 0)} simulations run", f"{st.get('cache_hits', 0)} cached scores used"]
    if st.get("cnn_batches"):
        facts.append(f"{st['cnn_ops']} CNN scores in {st['cnn_batches']} batches")
    if result.method == "rap":
        facts.append(f"simulator fallbacks: {st.get('fallbacks', 0)} of {st.get('decisions', 0)} "
                     f"decisions")
    if result.method == "search":
        how = (f"exact DP over {st.get('operations', '?')} operations" if st.get("search") == "exact"
               else f"beam of width {st.get('beam_width')}")
        facts.append(f"search: {how}, {st.get('predicted_operations', 0)} operations scored by "
                     f"the model, {st.get('search_simulations', 0)} simulated while planning")
    if result.method == "optimal" and "subassemblies" in st:
        facts.append(f"DP over {st['subassemblies']} subassemblies / {st['operations']} operations "
                     f"vs. {st['exhaustive_sequences']:,} sequences for an exhaustive search "
                     f"({st['dp_speedup']:.0f}x fewer step evaluations)")
    console.print("; ".join(facts))


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


def plan_command(
    assembly: Path = typer.Argument(..., help="Assembly JSON file."),
    model: Path = typer.Option(None, "--model", help="CNN checkpoint [default: the shipped model]."),
    method: str = typer.Option("search", "--method", help="search | rap | sim | optimal | random "
                               "(search, the default: the best product of the model's scores "
                               "over every sequence, dynamic programming or a beam; rap: the "
                               "paper's greedy planner)."),
    out: Path = typer.Option(None, "--out", "-o", help="Write the plan as JSON here."),
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
    samples: int = typer.Option(50, "--samples", min=1, help="Random sequences (method random)."),
    fallback_k: int = typer.Option(None, "--fallback-k", min=1, help="Method rap: when no "
                                   "candidate is predicted high, simulate at most the K most "
                                   "likely [default: every candidate, until one is good enough]."),
    high_probability: float = typer.Option(None, "--high-probability", help="Method rap: a "
                                           "candidate is taken without simulation at P(high) >= "
                                           "this [default: 0.9; the paper: 0.5]."),
    fallback_optimism: float = typer.Option(None, "--fallback-optimism", min=0.0, max=1.0,
                                            help="Method rap: the fallback simulates candidates "
                                            "best first until the best simulated score exceeds "
                                            "the next one's p + U (1 - p), p its expected score "
                                            "(1: all at once, the paper's rule with "
                                            "--high-probability 0.5) [default: 0.4]."),
    beam_width: int = typer.Option(None, "--beam-width", min=1, help="Method search: beam width "
                                   "beyond the exact search's budget [default: 8]."),
    simulations: int = typer.Option(None, "--simulations", min=0, help="Method search: "
                                    "simulations to spend while planning [default: 0]."),
    trust: float = typer.Option(None, "--trust", min=0.0, max=1.0, help="Method search: "
                                "operations predicted at this score or more are not simulated "
                                "while planning [default: none trusted]."),
    optimism: float = typer.Option(None, "--optimism", min=0.0, max=1.0, help="Method search "
                                   "with --simulations: an operation not simulated counts as "
                                   "p + OPTIMISM (1 - p) while choosing, so alternatives the model "
                                   "may underrate get simulated (0: the model as is; 1: the "
                                   "optimum, simulations permitting) [default: 0]."),
    workers: int = typer.Option(None, "--workers", min=1, help="Simulation processes here, or "
                                "actors with --address [default: all CPUs]."),
):
    """Plan a robust assembly sequence and print it (step, parts, direction, score, source)."""
    from rap.commands._console import console as make_console

    from rap.io import load_assembly
    from rap.plan.result import PlanStatus
    from rap.seeds import DEFAULT_ROOT_SEED

    console = make_console()
    err = make_console(stderr=True)
    if method not in METHODS:
        raise InputError(f"--method {method!r}: choose one of {', '.join(METHODS)}")
    if space not in ("online", "all"):
        raise InputError(f"--space {space!r}: choose online or all")
    if trust is not None and not 0.0 < trust <= 1.0:
        raise InputError(f"--trust {trust}: choose a score in (0, 1]")
    if high_probability is not None and not 0.0 < high_probability <= 1.0:
        raise InputError(f"--high-probability {high_probability}: choose a probability in (0, 1]")
    if (trust is not None or optimism) and not simulations:
        err.print("[yellow]warning:[/] --trust and --optimism choose what to simulate: without "
                  "--simulations N they change nothing")
    _check_suffix(out, "--out", (".json",))
    _check_suffix(picture, "--picture", (".png", ".svg"))
    if no_ray and address:
        raise InputError("--no-ray and --address exclude each other")
    if server is not None:
        given = [name for name, v, default in (
            ("--address", address, None), ("--no-ray", no_ray, False), ("--model", model, None),
            ("--trials", trials, 100), ("--space", space, "online"), ("--cache", cache, None),
            ("--no-cache", no_cache, False), ("--samples", samples, 50),
            ("--workers", workers, None))
            if v != default]
        if given:
            raise InputError(f"--server and {given[0]} exclude each other (the service plans with "
                             f"its own settings: model, trials, cache, workers)")
        server_options = {  # the method's options travel with the request
            "rap": {"fallback_k": fallback_k, "high_probability": high_probability,
                    "fallback_optimism": fallback_optimism},
            "search": {"beam_width": beam_width, "simulations": simulations, "trust": trust,
                       "optimism": optimism}}.get(method, {})
    asm = load_assembly(assembly)
    root_seed = DEFAULT_ROOT_SEED if seed is None else int(seed)

    t0 = time.perf_counter()
    on_ray = False
    if server is not None:
        from rap.client import plan_body, post_plan
        from rap.plan.result import PlanResult

        body = plan_body(assembly, method, seed, server_options)
        with console.status(f"planning {asm.name} with {method} at {server} ..."):
            doc, details = post_plan(server, body, token=token or os.environ.get("RAP_FARM_TOKEN"))
        try:
            result = PlanResult.from_json(doc, **details)
        except ValueError as exc:
            from rap.client import ServiceError

            raise ServiceError(f"--server {server}: {exc}") from None
        cache_path = None
    else:
        from rap.plan.cache import default_cache_path
        from rap.sim.params import SimParams

        params = SimParams(trials=trials)
        model_path, method = resolve_model(model, method, lambda s: err.print(s))
        cache_path = None if no_cache else (cache or default_cache_path())
        address = None if no_ray else (address or os.environ.get("RAY_ADDRESS") or None)
        if address is None:
            result = _plan_here(asm, method, params, root_seed, space, samples, model_path,
                                cache_path, _local_workers(workers), err,
                                dict(fallback_k=fallback_k, beam_width=beam_width,
                                     simulations=simulations, trust=trust,
                                     high_probability=high_probability, optimism=optimism,
                                     fallback_optimism=fallback_optimism))
        else:
            import rap.farm.service as service

            if model_path is not None:
                _familiarity(asm, _load_cnn(model_path), space, err)
            on_ray = True
            req = service.PlanRequest(asm, method, params, root_seed, space, samples,
                                      planner_options=dict(fallback_k=fallback_k,
                                                           beam_width=beam_width,
                                                           simulations=simulations,
                                                           trust=trust,
                                                           high_probability=high_probability,
                                                           optimism=optimism,
                                                           fallback_optimism=fallback_optimism))
            with console.status(f"planning {asm.name} with {method} on Ray at {address} ..."):
                result = service.run_plan(req, model_path=model_path, address=address,
                                          workers=workers,
                                          cache_path=str(cache_path) if cache_path else None)
    wall = time.perf_counter() - t0

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
    if out is not None:
        console.print(f"plan written to {write_plan_json(result, out)}")
    if picture is not None:
        from rap.render.pictures import storyboard

        path = storyboard(asm, result.steps, picture,
                          title=f"{asm.name}: {result.method}, R = {result.robustness:.3f}")
        console.print(f"storyboard written to {path}")
    if cache_path is not None:
        console.print(f"score cache: {cache_path}", style="dim")


def _load_cnn(model_path: str):
    from rap.model.inference import PredictorCnn

    return PredictorCnn.load(model_path, engine="auto")


def _plan_here(asm, method, params, root_seed, space, samples, model_path, cache_path, workers,
               err, options: dict | None = None):
    """Plan in this process; simulation batches over ``workers`` forked processes."""
    from rap.plan.cache import ScoreCache
    from rap.plan.methods import make_planner
    from rap.plan.problem import PlanningProblem
    from rap.plan.local_simulator import LocalSimulator
    from rap.plan.scorers import Scorer

    # simulation workers first: they load the simulator while this process loads the model,
    # renders and scores (see LocalSimulator's prestart)
    sim = LocalSimulator(processes=workers, prestart=True)
    try:
        cnn = _load_cnn(model_path) if model_path else None
        problem = PlanningProblem(asm, params, root_seed, space)
        if cnn is not None:
            _familiarity(asm, cnn, space, err, problem=problem)
            if sim.prestarted:
                cnn.cores_busy = sim.loading
        cache_obj = ScoreCache(cache_path)
        planner = make_planner(method, samples=samples, **(options or {}))
        result = planner.solve(problem, Scorer(sim, cnn, cache_obj))
    finally:
        sim.close()
    cache_obj.flush()
    return result


def _familiarity(asm, cnn, space: str, err, problem=None) -> None:
    """Warn when ``asm`` is far from what the model was trained on (checkpoint metadata)."""
    try:
        from rap.plan.problem import PlanningProblem
        from rap.plan.familiarity import familiarity_operations, model_familiarity
        from rap.sim.params import SimParams

        problem = problem or PlanningProblem(asm, SimParams(), space=space)
        images = cnn.images(problem, familiarity_operations(problem))
        notes = model_familiarity(cnn.meta, asm.geometry_hash, images)
    except RapError:
        raise
    except Exception as exc:  # a failed check must not stop planning
        notes = [f"could not compare the assembly with the model's training data ({exc})"]
    for n in notes:
        err.print(f"[yellow]warning:[/] {n}")


def register(app: typer.Typer) -> None:
    app.command("plan")(plan_command)

"""``rap-farm demo``: the whole pipeline at small scale on this machine, in a few minutes.

1. label a small dataset of the bundled assemblies on the local Ray (``rap.farm.driver``);
2. train the robustness CNN on it, holding the demo assembly out (``rap.model.train``);
3. plan the held-out assembly with RAP and, concurrently on the same planning service, with the
   simulator-only baseline (``rap.farm.service``);
4. write the plan (JSON), its storyboard (PNG) and a Markdown table, and say where everything went.
"""

from __future__ import annotations

import time
from pathlib import Path

import typer

__all__ = ["register", "demo_command", "bundled_assemblies"]


def bundled_assemblies() -> Path:
    """``./assemblies`` when run from a checkout, else the copies shipped in the package."""
    here = Path("assemblies")
    if here.is_dir() and any(here.glob("*.json")):
        return here
    import rap

    return Path(rap.__file__).resolve().parent / "data" / "assemblies"


def _markdown(result) -> str:
    lines = [f"# {result.assembly}: {result.method} plan, R = {result.robustness:.4f}", "",
             "| step | moving | fixed | direction | score | chosen by | P(high) |",
             "|---:|---|---|---|---:|---|---:|"]
    for i, s in enumerate(result.steps, 1):
        conf = "" if s.confidence is None else f"{s.confidence:.3f}"
        lines.append(f"| {i} | {','.join(s.moving)} | {','.join(s.fixed)} | "
                     f"({s.direction[0]:+.3f}, {s.direction[1]:+.3f}) | {s.score:.3f} | {s.source} | {conf} |")
    return "\n".join(lines) + "\n"


def demo_command(
    out: Path = typer.Option(Path("runs/demo"), "--out", "-o", help="Directory for every output."),
    assembly: str = typer.Option("hexagon", "--assembly",
                                 help="Assembly to plan (held out of training)."),
    assemblies: Path = typer.Option(None, "--assemblies",
                                    help="Directory of assembly JSON files [default: bundled]."),
    ops: int = typer.Option(300, "--ops", min=4, help="Labelled operations per assembly."),
    trials: int = typer.Option(30, "--trials", min=1, help="Simulator trials per operation."),
    epochs: int = typer.Option(8, "--epochs", min=1, help="Training epochs."),
    seed: int = typer.Option(0, "--seed", help="Root seed (labels, training, planning)."),
    workers: int = typer.Option(None, "--workers", min=1, help="Simulation actors [default: all CPUs]."),
):
    """Label, train and plan at small scale on the local Ray; writes everything under --out."""
    from rap.commands._console import console as make_console

    from rap.commands.plan import print_result, write_plan_json
    from rap.errors import InputError
    from rap.plan.result import PlanStatus

    console = make_console()
    src = assemblies or bundled_assemblies()
    files = sorted(Path(src).glob("*.json"))
    if not files:
        raise InputError(f"--assemblies {src}: no assembly JSON files")
    by_name = {f.stem: f for f in files}
    if assembly not in by_name:
        raise InputError(f"--assembly {assembly}: not among {', '.join(sorted(by_name))}")
    out = Path(out)
    dataset, model_path = out / "dataset", out / "model.pt"
    plan_json, picture, table = out / "plan.json", out / "storyboard.png", out / "plan.md"
    out.mkdir(parents=True, exist_ok=True)
    t_all = time.perf_counter()

    import rap.farm.service as service
    from rap.io import load_assembly
    from rap.farm.driver import LabelConfig, format_summary, run_label
    from rap.farm.runtime import connect
    from rap.sim.params import SimParams

    with connect(None, num_cpus=workers) as rt:
        console.rule(f"1/3 label {len(files)} assemblies ({ops} operations each, {trials} trials) "
                     f"on local Ray ({rt.cpus} CPUs)")
        t = time.perf_counter()
        summary = run_label(LabelConfig(assemblies=tuple(str(f) for f in files), out=str(dataset),
                                        workers=workers, trials=trials, seed=seed,
                                        max_ops_per_assembly=ops, command="rap-farm demo"))
        console.print(format_summary(summary))
        t_label = time.perf_counter() - t

        console.rule(f"2/3 train the CNN without {assembly}")
        from rap.commands.train import progress_bar
        from rap.model.train import TrainConfig, train

        t = time.perf_counter()
        bar, on_step = progress_bar(console)
        with bar:
            res = train(dataset, holdout=assembly, config=TrainConfig(epochs=epochs, seed=seed),
                        on_step=on_step)
        res.save(model_path)
        h = res.metrics.get("holdout", {})
        if h:
            console.print(f"held-out {assembly}: accuracy {h.get('accuracy', float('nan')):.3f} on "
                          f"{h.get('rows', 0)} rows")
        t_train = time.perf_counter() - t

        console.rule(f"3/3 plan {assembly} with RAP (and the sim-only baseline, concurrently)")
        asm = load_assembly(by_name[assembly])
        params = SimParams(trials=trials)
        t = time.perf_counter()
        reqs = [service.PlanRequest(asm, m, params, seed, cold=True) for m in ("rap", "sim")]
        rap_res, sim_res = service.run_plans(reqs, model_path=str(model_path), workers=workers)
        t_plan = time.perf_counter() - t

    for r in (rap_res, sim_res):
        if r.status is not PlanStatus.FOUND:
            raise InputError(f"demo: {r.method} plan failed: {r.message}")
    print_result(console, rap_res)
    console.print(f"sim-only baseline: R = {sim_res.robustness:.4f} in {sim_res.seconds:.2f} s "
                  f"(RAP: R = {rap_res.robustness:.4f} in {rap_res.seconds:.2f} s, "
                  f"{sim_res.seconds / max(rap_res.seconds, 1e-9):.1f}x faster)")
    write_plan_json(rap_res, plan_json)
    from rap.render.pictures import storyboard

    storyboard(asm, rap_res.steps, picture, title=f"{asm.name}: RAP, R = {rap_res.robustness:.3f}")
    table.write_text(_markdown(rap_res) + "\n" + _markdown(sim_res), encoding="utf-8")
    console.rule("outputs")
    for what, p in (("dataset (Parquet)", dataset), ("CNN checkpoint", model_path),
                    ("plan (JSON)", plan_json), ("storyboard", picture), ("tables (Markdown)", table)):
        console.print(f"{what:20s} {p}")
    console.print(f"time: label {t_label:.0f} s, train {t_train:.0f} s, plan {t_plan:.0f} s, "
                  f"total {time.perf_counter() - t_all:.0f} s")
    console.print(f"next: rap-farm plan assemblies/{assembly}.json --model {model_path} "
                  f"--picture plan.png")


def register(app: typer.Typer) -> None:
    app.command("demo")(demo_command)

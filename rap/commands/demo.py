"""``rap-farm demo``: what rap-farm does, on this machine, in about two minutes.

1. **The pipeline at small scale**, labelled as such: label a small dataset of the bundled
   assemblies on the local Ray (``rap.farm.driver``), train a small robustness CNN without the
   demo assembly (``rap.model.training.train``) and evaluate it on that held-out assembly (accuracy and the
   labels' noise ceiling). Minutes of data and training: it shows the steps, not the product.
2. **The product**: ``rap-farm plan``'s default (``search`` with the shipped model) against
   simulator-only greedy (``--method sim``) on ``packing-s100`` (the packing family's seed 100,
   one of ``assemblies/unseen``), which the shipped model was not trained on (its checkpoint's
   list says so, checked here). Each is a ``rap-farm plan FILE --no-cache`` run of its own, one
   after the other, so both start from a cold score cache and have the machine to themselves:
   robustness R and planning time of each.
3. Writes the dataset, the small model, both plans (JSON), the search plan's storyboard (PNG) and
   a Markdown table, and says where everything went.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import typer

__all__ = ["register", "demo_command", "bundled_assemblies", "COMPARE"]

#: the assembly of the comparison: (family, seed) of ``rap.geometry.families.generate``
COMPARE = ("packing", 100)


def bundled_assemblies() -> Path:
    """``./assemblies`` when run from a checkout, else the copies shipped in the package."""
    here = Path("assemblies")
    if here.is_dir() and any(here.glob("*.json")):
        return here
    from rap.assembly import SHIPPED_ASSEMBLIES

    return SHIPPED_ASSEMBLIES


def _markdown(doc: dict, title: str) -> str:
    lines = [f"# {doc['assembly']}: {title}, R = {doc['robustness']:.4f}", "",
             "| step | moving | fixed | insertion | score | chosen by | P(high) |",
             "|---:|---|---|---|---:|---|---:|"]
    for i, s in enumerate(doc["steps"], 1):
        conf = "" if s.get("confidence") is None else f"{s['confidence']:.3f}"
        dx, dy = s["insertion"] if "insertion" in s else s["direction"]
        lines.append(f"| {i} | {','.join(s['moving'])} | {','.join(s['fixed'])} | "
                     f"({dx:+.3f}, {dy:+.3f}) | {s['score']:.3f} | {s['source']} | {conf} |")
    return "\n".join(lines) + "\n"


def _small_scale(console, files, assembly, out, ops, trials, epochs, seed, workers) -> dict:
    """Steps 1-3: label, train without ``assembly``, evaluate on it; their times in seconds."""
    from rap.farm.driver import LabelConfig, format_summary, run_label
    from rap.farm.runtime import connect

    times = {}
    with connect(None, num_cpus=workers) as rt:
        console.rule(f"1/4 label {len(files)} assemblies ({ops} operations each, {trials} trials) "
                     f"on local Ray ({rt.cpus} CPUs)")
        t = time.perf_counter()
        summary = run_label(LabelConfig(assemblies=tuple(str(f) for f in files),
                                        out=str(out / "dataset"), workers=workers, trials=trials,
                                        seed=seed, max_ops_per_assembly=ops,
                                        command="rap-farm demo"))
        console.print(format_summary(summary))
        times["label"] = time.perf_counter() - t
    epochs_text = f"{epochs} epoch" + ("s" if epochs != 1 else "")
    console.rule(f"2/4 train a small CNN without {assembly} ({epochs_text})")
    from rap.commands.train import progress_bar
    from rap.model.training.train import TrainConfig, train

    t = time.perf_counter()
    bar, on_step = progress_bar(console)
    with bar:
        res = train(out / "dataset", holdout=assembly, config=TrainConfig(epochs=epochs, seed=seed),
                    on_step=on_step)
    res.save(out / "model.pt")
    times["train"] = time.perf_counter() - t
    console.rule(f"3/4 evaluate it on {assembly}, held out of its training")
    h = res.metrics.get("holdout", {})
    console.print(f"held-out {assembly}: accuracy {h.get('accuracy', float('nan')):.3f} on "
                  f"{h.get('rows', 0)} rows (high/low robustness at 0.95); the labels' noise "
                  f"ceiling {h.get('ceiling', float('nan')):.3f}")
    console.print(f"(a small model: {summary.existing + summary.labelled} labelled operations, "
                  f"{epochs_text}; it shows the steps, not the product: the shipped model below "
                  f"learned from a corpus of hundreds of assemblies)")
    return times


def _plan(path: Path, method: str, out_json: Path, picture: Path | None,
          workers: int | None) -> tuple[dict, str]:
    """One ``rap-farm plan`` run in a process of its own: (plan document, what it printed)."""
    argv = [sys.executable, "-m", "rap.cli", "plan", str(path), "--method", method, "--no-cache",
            "--out", str(out_json)]
    if picture is not None:
        argv += ["--picture", str(picture)]
    if workers is not None:
        argv += ["--workers", str(workers)]
    done = subprocess.run(argv, capture_output=True, text=True)
    if done.returncode != 0:
        from rap.errors import WorkFailedError

        why = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise WorkFailedError(f"demo: rap-farm plan --method {method} {path} failed "
                              f"(exit {done.returncode}): {why}")
    return json.loads(out_json.read_text(encoding="utf-8")), done.stdout + done.stderr


def _compare(console, out: Path, workers: int | None) -> tuple[dict, dict, float]:
    """Step 4: search with the shipped model against simulator-only greedy on ``COMPARE``."""
    import numpy as np

    from rap.commands.plan import default_model_path
    from rap.geometry.families import generate
    from rap.io import assembly_to_json
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.scoring.familiarity import model_familiarity

    asm = generate(*COMPARE)
    path = out / f"{asm.name}.json"
    path.write_text(json.dumps(assembly_to_json(asm)), encoding="utf-8")
    meta = OperationPredictor.load(default_model_path(), engine="cnn").meta  # meta only
    seen = model_familiarity(meta, asm.geometry_hash, np.zeros((0, 2, 64, 64), np.uint8))
    console.rule("4/4 the product: rap-farm plan's default against simulator-only greedy")
    console.print(f"{asm.name} ({len(asm)} parts, {path}): "
                  + (seen[0] if seen else f"not among the {len(meta['assemblies'])} assemblies "
                     f"the shipped model was trained on"), highlight=False)
    console.print("each plan is a `rap-farm plan FILE --no-cache` of its own, one after the other",
                  highlight=False)
    t = time.perf_counter()
    search, shown = _plan(path, "search", out / "plan.json", out / "storyboard.png", workers)
    console.print(shown.rstrip("\n"), highlight=False, markup=False)
    sim, _ = _plan(path, "sim", out / "plan-sim.json", None, workers)
    return search, sim, time.perf_counter() - t


def _verdict(console, search: dict, sim: dict) -> None:
    """R and planning time of each plan, and how they compare (whichever way that goes)."""
    for label, doc, note in (
            ("search (default), shipped model", search,
             f"  (its {len(search['steps'])} steps then simulated, to measure R)"),
            ("sim: simulator-only greedy", sim, "")):
        console.print(f"{label:32s} R = {doc['robustness']:.3f}   planning "
                      f"{doc['seconds']:6.2f} s{note}", highlight=False)
    console.print(f"search: {search['robustness'] - sim['robustness']:+.3f} in R, in "
                  f"{search['seconds'] / max(sim['seconds'], 1e-9):.2f}x the planning time (one "
                  f"assembly; the twelve of assemblies/unseen: docs/RESULTS.md)", highlight=False)


def demo_command(
    out: Path = typer.Option(Path("runs/demo"), "--out", "-o", help="Directory for every output."),
    assembly: str = typer.Option("hexagon", "--assembly",
                                 help="Assembly held out of the small-scale training and "
                                      "evaluated on."),
    assemblies: Path = typer.Option(None, "--assemblies",
                                    help="Directory of assembly JSON files to label "
                                         "[default: bundled]."),
    ops: int = typer.Option(200, "--ops", min=4, help="Labelled operations per assembly."),
    trials: int = typer.Option(30, "--trials", min=1, help="Simulator trials per labelled "
                               "operation (the plans use plan's default, 100)."),
    epochs: int = typer.Option(6, "--epochs", min=1, help="Training epochs."),
    seed: int = typer.Option(0, "--seed", help="Root seed of the labels and the training (the "
                             "plans use plan's default)."),
    workers: int = typer.Option(None, "--workers", min=1, help="Simulation actors and plan "
                                "processes [default: all CPUs]."),
):
    """The pipeline at small scale (label, train, evaluate), then the shipped model's default plan
    against simulator-only greedy; writes everything under --out."""
    from rap.commands._console import console as make_console
    from rap.errors import InputError

    console = make_console()
    src = assemblies or bundled_assemblies()
    files = sorted(Path(src).glob("*.json"))
    if not files:
        raise InputError(f"--assemblies {src}: no assembly JSON files")
    names = {f.stem for f in files}
    if assembly not in names:
        raise InputError(f"--assembly {assembly}: not among {', '.join(sorted(names))}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t_all = time.perf_counter()
    console.rule("a small-scale run of the pipeline: label -> train -> evaluate", style="bold")
    times = _small_scale(console, files, assembly, out, ops, trials, epochs, seed, workers)
    search, sim, times["plan"] = _compare(console, out, workers)
    _verdict(console, search, sim)
    (out / "plan.md").write_text(_markdown(search, "search, shipped model") + "\n"
                                 + _markdown(sim, "simulator-only greedy"), encoding="utf-8")
    console.rule("outputs")
    for what, name in (("dataset (Parquet)", "dataset"), ("small CNN", "model.pt"),
                       ("assembly", f"{search['assembly']}.json"), ("search plan", "plan.json"),
                       ("sim-only plan", "plan-sim.json"), ("storyboard", "storyboard.png"),
                       ("tables (Markdown)", "plan.md")):
        console.print(f"{what:20s} {out / name}")
    console.print(f"time: label {times['label']:.0f} s, train {times['train']:.0f} s, plans "
                  f"{times['plan']:.0f} s, total {time.perf_counter() - t_all:.0f} s")
    console.print("next: rap-farm generate polyomino --seed 100 -o polyomino.json && "
                  "rap-farm plan polyomino.json --picture plan.png", highlight=False)


def register(app: typer.Typer) -> None:
    app.command("demo")(demo_command)

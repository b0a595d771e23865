"""Grow the corpus with new kinds of assembly and fine-tune: does it pay? (issue 30, item 6)

A measured experiment; nothing here changes the shipped model, ``rap/data``, ``datasets/`` or a
default. Everything it writes is under ``reports/grow/`` (git-ignored). Steps, in order::

    python -m research.grow_corpus assemblies        # reports/grow/assemblies/*.json
    python -m research.grow_corpus label             # rap-farm label -> reports/grow/dataset
    python -m research.grow_corpus mix               # + a corpus sample -> reports/grow/mix
    (python -m research.grow_corpus unsure; ... mix --new reports/grow/unsure: the unsure rows only)
    python -m research.grow_corpus train             # rap-farm train --init -> reports/grow/ft.pt
    python -m research.grow_corpus measure [--plans] # shipped vs fine-tuned on unseen and fresh
    # the control, without the new rows (what fine-tuning on the corpus sample alone does):
    python -m research.grow_corpus mix --new none --mix reports/grow/control
    python -m research.grow_corpus train --mix reports/grow/control --model reports/grow/control.pt
    python -m research.grow_corpus measure --model reports/grow/control.pt --plans

* ``assemblies``: new kinds that are not the unseen test set's: pentomino tilings of 5 x 12,
  4 x 15 and 3 x 20 and basketweaves of 2 x 2 and 4 x 2 blocks (``scripts/make_unseen.py``'s
  generators; the test set has pentomino 6 x 10 and basketweave 3 x 2; basketweave 2 x 3 is left
  out: it is the 3 x 2 one turned by 90 degrees). Refuses a geometry hash equal to an unseen
  assembly's. They are the test set's new kinds at other sizes: the favourable case for growing.
* ``label``: ``rap-farm label`` as ``make_unseen`` labels (root seed 20190527, 100 trials, at most
  420 operations per assembly, three directions per merged range), ``--workers`` (2).
* ``mix``: ``rap-farm train`` takes one dataset directory, so the training set is a directory of
  hard links: the new rows plus the corpus's assemblies of seeds ``--corpus-seeds`` (default 0-3,
  40 assemblies, 15,742 rows) of the ten families, against forgetting them; ``--new``:
  the new rows to add, all (``reports/grow/dataset``) or only the unsure ones.
* ``unsure``: the new rows the shipped model is least sure of (P(high) in ``--band``, default
  [0.2, 0.8]) or wrong on, into ``reports/grow/unsure`` (one CNN pass over the new rows).
* ``train``: ``rap-farm train reports/grow/mix --init rap/data/default_model.pt --epochs E
  --lr LR --threads 2 --descriptors all --batch-size 256`` (the shipped model's recipe and
  network, else ``--init`` is refused; calibrated on a tenth of the mix's assemblies).
* ``measure``: per assembly of ``unseen`` (test) and ``fresh`` (the ten families' validation
  set) the class accuracy (P(high) >= 0.5 against a score >= 0.95, as ``rap-farm score``) beside
  the noise ceiling of the 100-trial scores (``rap.model.evaluation.metrics``), shipped vs fine-tuned, on
  every operation of the graph; the truth and the shipped model's numbers are the cached tables
  ``reports/search-validation/{fresh,unseen}.pkl``, the fine-tuned model's are computed on exactly
  those operations (``research.validation_tables.predictions``). ``--plans``: also the replayed
  plan quality (``research.bound_coverage.replay``, setting ``--setting``, default
  ``b200-c95-u35``, the plan default) with each model's numbers; the bounds are
  the shipped ones, calibrated for the shipped model (so the fine-tuned plans' bounds are not
  calibrated; R / R opt still compares).

Cost measured on this 2-core machine (each step prints its wall time): ``label`` 2,100
operations in 324 s (6.7 a second); ``unsure`` 19 s; ``train`` 2 epochs of about 16,500 rows in
277 s alone (130 rows a second; 550-610 s while another job shared the cores); ``measure`` one
CNN pass over the 23 graphs' 17,552 operations, about 300 s alone, ``--plans`` 20 s.

Result (2 epochs, lr 3e-4, corpus seeds 0-3): unseen accuracy / noise ceiling 0.887 shipped;
with the new rows 0.913 (seed 0) and 0.898 (seed 1), the unsure rows only 0.895 (seed 1); the
control without them 0.891 (seed 0) and 0.912 (seed 1). The seeds' spread (0.02) is larger than
what the new rows add (+0.004 on the mean of two seeds): growing with these kinds does not pay
measurably; short fine-tuning by itself moves the ratio by -0.01..+0.03 from seed to seed.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "reports" / "grow"
ASSEMBLIES = OUT / "assemblies"
DATASET = OUT / "dataset"
MIX = OUT / "mix"
UNSURE = OUT / "unsure"
CORPUS = ROOT / "datasets" / "corpus"
SHIPPED = ROOT / "rap" / "data" / "default_model.pt"
SEED = 20190527
PENTOMINO = ((12, 5), (15, 4), (20, 3))  # (cols, rows); the test set's is 10 x 6
BASKETWEAVE = ((2, 2), (4, 2))  # (blocks_x, blocks_y); the test set's is 3 x 2 (2 x 3: it, turned)


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "rap.cli", *args]


def _run(cmd: list[str]) -> float:
    print(" ".join(cmd), flush=True)
    t = time.perf_counter()
    rc = subprocess.call(cmd, env={**os.environ, "PYTHONPATH": str(ROOT)})
    if rc:
        sys.exit(rc)
    return time.perf_counter() - t


def make_assemblies() -> list[Path]:
    """The new kinds, verified, written to ``reports/grow/assemblies``; none shares a geometry
    hash with an unseen assembly."""
    sys.path.insert(0, str(ROOT / "scripts"))
    from make_unseen import basketweave, pentomino_tiling

    from rap.assembly import Assembly, assembly_to_json
    from rap.geometry.families.base import make_part, verify
    from rap.geometry.families.packings import union_ring
    from rap.io import load_assembly

    test = {load_assembly(p).geometry_hash: p.stem
            for p in sorted((ROOT / "assemblies" / "unseen").glob("*.json"))}
    kinds = {f"basketweave-{bx}x{by}": basketweave(bx, by) for bx, by in BASKETWEAVE}
    for cols, rows in PENTOMINO:
        kinds[f"pentomino-{rows}x{cols}"] = {
            name: union_ring([(x * 10, y * 10, x * 10 + 10, y * 10 + 10) for x, y in cells])
            for name, cells in pentomino_tiling(cols, rows).items()}
    ASSEMBLIES.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, parts in kinds.items():
        a = Assembly(name, tuple(make_part(pid, pts) for pid, pts in parts.items()),
                     family="grow")
        verify(a)
        if a.geometry_hash in test:
            sys.exit(f"{name}: the geometry of the test assembly {test[a.geometry_hash]}")
        p = ASSEMBLIES / f"{name}.json"
        p.write_text(json.dumps(assembly_to_json(a), separators=(",", ":")) + "\n")
        paths.append(p)
        print(f"{p}: {len(a)} parts")
    return paths


def label(workers: int) -> None:
    paths = sorted(ASSEMBLIES.glob("*.json"))
    geometry = DATASET / "_assemblies"
    geometry.mkdir(parents=True, exist_ok=True)
    for p in paths:
        shutil.copyfile(p, geometry / p.name)
    s = _run(_cli("label", *map(str, paths), "--out", str(DATASET), "--seed", str(SEED),
                  "--trials", "100", "--max-ops-per-assembly", "420", "--directions-per-range",
                  "3", "--workers", str(workers), "--quiet"))
    print(f"label: {s:.0f} s")


def unsure(lo: float, hi: float) -> None:
    """``reports/grow/unsure``: the new rows the shipped model is least sure of or wrong on:
    P(high) in [``lo``, ``hi``] or its class (P(high) >= 0.5) not the label's (score >= 0.95).
    One CNN pass over the new rows (descriptors from the dataset's geometry, as
    ``rap.model.evaluation.cross_validation.score_checkpoint``)."""
    import pyarrow.parquet as pq

    from rap.dataset import decode_images, shard_files
    from rap.model.inference.torch_engine import TorchPredictor
    from rap.model.data.views import DatasetGeometry

    if UNSURE.exists():
        shutil.rmtree(UNSURE)
    shutil.copytree(DATASET / "_assemblies", UNSURE / "_assemblies")
    shutil.copyfile(DATASET / "_rapfarm.json", UNSURE / "_rapfarm.json")
    pred = TorchPredictor.load(SHIPPED, device="cpu")
    geometry = DatasetGeometry(DATASET)
    kept = total = 0
    for f in shard_files(DATASET):
        t = pq.read_table(f)
        c = {k: t.column(k).to_pylist() for k in ("assembly", "geometry_hash", "moving", "fixed",
                                                     "direction_x", "direction_y")}
        d = geometry.descriptors(pred.descriptors, c["assembly"], c["geometry_hash"], c["moving"],
                                 c["fixed"], list(zip(c["direction_x"], c["direction_y"])))
        p = pred.prob_high(decode_images(t.column("image")), d)
        high = t.column("score").to_numpy() >= pred.threshold
        keep = ((p >= lo) & (p <= hi)) | ((p >= 0.5) != high)
        (UNSURE / f.parent.name).mkdir(exist_ok=True)
        pq.write_table(t.filter(keep), UNSURE / f.parent.name / f.name)
        kept, total = kept + int(keep.sum()), total + len(p)
    print(f"{UNSURE}: {kept} of {total} new rows (P(high) in [{lo}, {hi}] or wrong)")


def mix(seeds: range, new: Path | None = DATASET, out: Path = MIX) -> None:
    """``reports/grow/mix``: hard links to the shards of ``new`` (the new rows, or the unsure
    ones) and to the corpus's shards of ``seeds``, with their geometry and the new dataset's
    metadata."""
    import pyarrow.parquet as pq

    from rap.dataset import shard_files

    if out.exists():
        shutil.rmtree(out)
    (out / "_assemblies").mkdir(parents=True)
    shutil.copyfile(DATASET / "_rapfarm.json", out / "_rapfarm.json")
    keep = {f"-s{s}" for s in seeds}
    rows = {"new": 0, "corpus": 0}
    for src, kind in ((new, "new"), (CORPUS, "corpus")) if new else ((CORPUS, "corpus"),):
        for f in shard_files(src):
            name = f.parent.name
            if kind == "corpus" and not any(name.endswith(k) for k in keep):
                continue
            (out / name).mkdir(exist_ok=True)
            os.link(f, out / name / f.name)
            g = src / "_assemblies" / f"{name}.json"
            if g.exists() and not (out / "_assemblies" / g.name).exists():
                shutil.copyfile(g, out / "_assemblies" / g.name)
            rows[kind] += pq.ParquetFile(f).metadata.num_rows
    print(f"{out}: {rows['new']} new rows, {rows['corpus']} corpus rows "
          f"({len(list(out.iterdir())) - 2} assemblies)")


def train(epochs: int, lr: float, out: Path, seed: int, data: Path = MIX) -> None:
    s = _run(_cli("train", str(data), "--init", str(SHIPPED), "--seed", str(seed), "--epochs",
                  str(epochs), "--lr", str(lr), "--threads", "2", "--out", str(out), "--restart",
                  "--descriptors", "all", "--batch-size", "256"))  # the shipped network, batch
    print(f"train: {s:.0f} s")


def _metrics(rows):
    """(rows, accuracy, ceiling) of (truth, P(high)) pairs, as ``rap-farm score``."""
    import numpy as np

    from rap.model.evaluation.metrics import classification_metrics

    s = np.array([t for t, _ in rows])
    ph = np.array([p for _, p in rows])
    m = classification_metrics((s >= 0.95).astype(int), ph, np.rint(s * 100).astype(int),
                               np.full(s.size, 100), reliability=False)
    return m["rows"], m["accuracy"], m["ceiling"]


def measure(model: Path, plans: bool, setting: str) -> None:
    """Shipped vs ``model`` on the cached tables of unseen and fresh (module doc)."""
    from rap.model.inference.operations import OperationPredictor
    from rap.plan.graph import reachable
    from research.validation_tables import assemblies_of, problem_of, saved_tables

    report = {}
    for split in ("unseen", "fresh"):
        names = assemblies_of(split)
        tabs = saved_tables(ROOT / "reports" / "search-validation", split, names)
        t = time.perf_counter()
        ft = {}
        cnn = OperationPredictor.load(model, engine="cnn")
        for n in names:  # as validation_tables.predictions, both numbers in one pass
            problem = problem_of(n)
            ops = [op for c in reachable(problem).values() for op in c]
            keys = [problem.key(op) for op in ops]
            ph, ex = (dict(zip(keys, map(float, x)))
                      for x in cnn.prob_high_and_expected(problem, ops))
            ft[n] = {"truth": tabs[n]["truth"], "phigh": {k: ph[k] for k in tabs[n]["truth"]},
                     "pred": {k: ex[k] for k in tabs[n]["truth"]}}
        print(f"\n{split}: predictions of {model.name} in {time.perf_counter() - t:.0f} s")
        print(f"| {split} | ops | ceiling | shipped acc | ratio | fine-tuned acc | ratio |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        both = {"shipped": tabs, "fine-tuned": ft}
        for n in names + ["all"]:
            keys = names if n == "all" else [n]
            cells = []
            for tb in both.values():
                r, acc, ceil = _metrics([(tb[k]["truth"][x], tb[k]["phigh"][x])
                                         for k in keys for x in tb[k]["truth"]])
                cells.append((acc, ceil))
            (a0, _), (a1, _) = cells
            print(f"| {n} | {r} | {100 * ceil:.1f} | {100 * a0:.1f} | {a0 / ceil:.3f} | "
                  f"{100 * a1:.1f} | {a1 / ceil:.3f} |")
            report.setdefault(split, {})[n] = {"rows": r, "ceiling": ceil,
                                               "shipped": cells[0][0], "fine-tuned": cells[1][0]}
        if plans:
            report[split]["plans"] = _plans(names, both, setting)
    (OUT / f"measure-{model.stem}.json").write_text(json.dumps(report, indent=1))


def _plans(names, both: dict, setting: str) -> dict:
    """R / R opt and simulations of ``setting`` replayed with each model's numbers."""
    import statistics

    from research.bound_coverage import optimum, replay
    from research.validation_tables import problem_of
    from rap.model.calibration import load
    from rap.plan.graph import reachable

    bounds = load(None)
    rows = {m: [] for m in both}
    t = time.perf_counter()
    for n in names:
        problem = problem_of(n)
        graph = reachable(problem)
        best = optimum(problem, graph, both["shipped"][n]["truth"])
        for m, tabs in both.items():
            rows[m].append(replay(setting, n, tabs[n], bounds, problem, graph, best))
    print(f"\nplans ({setting}, shipped bounds) in {time.perf_counter() - t:.0f} s")
    print("| assembly | R opt | shipped R/Ropt | sims | fine-tuned R/Ropt | sims |")
    print("|---|---:|---:|---:|---:|---:|")
    for a, b in zip(rows["shipped"], rows["fine-tuned"]):
        print(f"| {a['assembly']} | {a['optimum']:.3f} | {a['ratio']:.3f} | {a['simulations']} | "
              f"{b['ratio']:.3f} | {b['simulations']} |")
    out = {}
    for m, rs in rows.items():
        out[m] = {"ratio": statistics.mean(x["ratio"] for x in rs),
                  "worst": min(x["ratio"] for x in rs),
                  "simulations": statistics.mean(x["simulations"] for x in rs)}
    print("| mean | | {:.3f} (worst {:.3f}) | {:.0f} | {:.3f} (worst {:.3f}) | {:.0f} |".format(
        out["shipped"]["ratio"], out["shipped"]["worst"], out["shipped"]["simulations"],
        out["fine-tuned"]["ratio"], out["fine-tuned"]["worst"], out["fine-tuned"]["simulations"]))
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("assemblies", "label", "unsure", "mix", "train", "measure"))
    ap.add_argument("--band", default="0.2,0.8", help="unsure: the P(high) band LO,HI")
    ap.add_argument("--new", default=str(DATASET),
                    help="mix: the new rows (or reports/grow/unsure; 'none': the control, "
                         "the corpus sample alone)")
    ap.add_argument("--mix", type=Path, default=MIX, help="mix, train: the training set's dir")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--corpus-seeds", default="0-3", help="corpus seeds in the mix: A-B")
    ap.add_argument("--epochs", type=int, default=2)
    ap.add_argument("--lr", type=float, default=3e-4)
    ap.add_argument("--seed", type=int, default=1, help="train: seed 1 holds out no new assembly "
                    "for calibration (seed 0 holds out basketweave-4x2 and pentomino-3x20)")
    ap.add_argument("--model", type=Path, default=OUT / "ft.pt")
    ap.add_argument("--plans", action="store_true")
    ap.add_argument("--setting", default="b200-c95-u35")
    a = ap.parse_args(argv)
    if a.what == "assemblies":
        make_assemblies()
    elif a.what == "label":
        label(a.workers)
    elif a.what == "unsure":
        unsure(*map(float, a.band.split(",")))
    elif a.what == "mix":
        lo, hi = map(int, a.corpus_seeds.split("-"))
        mix(range(lo, hi + 1), None if a.new == "none" else Path(a.new), a.mix)
    elif a.what == "train":
        train(a.epochs, a.lr, a.model, a.seed, a.mix)
    else:
        measure(a.model, a.plans, a.setting)


if __name__ == "__main__":
    main()

"""Wall time of ``rap-farm plan`` on a 7-part assembly, as a user runs it (a subprocess).

Each configuration runs ``repeats`` times (median printed, with min and max); every run is a fresh
process, so interpreter start-up, imports, model loading, the NDBG, the CNN, the simulator's
evaluation of the returned sequence and printing are all included:

* ``cold``: an empty score cache per run (``--cache`` in a new temporary file): every step of the
  returned sequence is simulated (100 trials each);
* ``warm``: the default behaviour of repeated calls, the score cache already holding the scores;
* ``sim, cold`` and ``sim, cold, 1 process``: the simulator-only method (every candidate of every
  step simulated, batches large enough for the worker processes), with the default workers and
  with ``--workers 1``.

    python benchmarks/plan.py [--assembly assemblies/hexagon.json] [--repeats 3] [--method rap]
        [--model CKPT ...] [--no-sim]

With several ``--model`` checkpoints the cold and warm runs of each alternate, run by run, so that
they are compared under the same load; ``--no-sim`` skips the simulator-only configurations.

Also prints the machine's CPU count and load average: the figures depend on what else runs.
"""

from __future__ import annotations

import argparse
import itertools
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(args: list[str], env: dict) -> float:
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "rap.cli", "plan", *args], capture_output=True,
                       text=True, env=env, cwd=ROOT)
    wall = time.perf_counter() - t
    if p.returncode != 0:
        sys.exit(f"rap-farm plan {' '.join(args)} failed ({p.returncode}):\n{p.stderr}")
    return wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--assembly", default=str(ROOT / "assemblies" / "hexagon.json"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--method", default="rap")
    ap.add_argument("--model", action="append", default=None,
                    help="a checkpoint to plan with (repeatable; default: the shipped model)")
    ap.add_argument("--no-sim", action="store_true", help="skip the simulator-only runs")
    a = ap.parse_args()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("RAY_ADDRESS", None)
    models = a.model or [None]
    bases = {m: [a.assembly, "--method", a.method] + (["--model", m] if m else []) for m in models}
    print(f"rap-farm plan {Path(a.assembly).name} --method {a.method}: {os.cpu_count()} CPUs, "
          f"load average {os.getloadavg()[0]:.2f} at start")
    with tempfile.TemporaryDirectory() as tmp:
        n = itertools.count()

        def cold(extra):
            return [run(extra + ["--cache", str(Path(tmp) / f"c{next(n)}.json")], env)
                    for _ in range(a.repeats)]

        def label(what, m):
            return what if len(models) == 1 else f"{what} {Path(m).stem if m else 'shipped'}"

        colds = {m: [] for m in models}
        for _ in range(a.repeats):  # alternate the models run by run
            for m in models:
                colds[m].append(run(bases[m] + ["--cache", str(Path(tmp) / f"c{next(n)}.json")],
                                    env))
        for m in models:
            report(label("cold", m), colds[m])
        warms = {m: [] for m in models}
        for m in models:
            run(bases[m] + ["--cache", str(Path(tmp) / f"warm{models.index(m)}.json")], env)
        for _ in range(a.repeats):
            for m in models:
                warms[m].append(run(bases[m] + ["--cache",
                                                str(Path(tmp) / f"warm{models.index(m)}.json")],
                                    env))
        for m in models:
            report(label("warm", m), warms[m])
        if a.no_sim:
            print(f"load average {os.getloadavg()[0]:.2f} at the end")
            return
        sim = [a.assembly, "--method", "sim"]
        report("sim, cold", cold(sim))
        report("sim, cold, 1 process", cold(sim + ["--workers", "1"]))
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


def report(label: str, walls: list[float]) -> None:
    print(f"  {label:22s} wall median {statistics.median(walls):5.2f} s "
          f"(min {min(walls):.2f}, max {max(walls):.2f}, n={len(walls)})")


if __name__ == "__main__":
    main()

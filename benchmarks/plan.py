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
    a = ap.parse_args()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("RAY_ADDRESS", None)
    base = [a.assembly, "--method", a.method]
    print(f"rap-farm plan {Path(a.assembly).name} --method {a.method}: {os.cpu_count()} CPUs, "
          f"load average {os.getloadavg()[0]:.2f} at start")
    with tempfile.TemporaryDirectory() as tmp:
        n = itertools.count()

        def cold(extra):
            return [run(extra + ["--cache", str(Path(tmp) / f"c{next(n)}.json")], env)
                    for _ in range(a.repeats)]

        report("cold", cold(base))
        warm = str(Path(tmp) / "warm.json")
        run(base + ["--cache", warm], env)
        report("warm", [run(base + ["--cache", warm], env) for _ in range(a.repeats)])
        sim = [a.assembly, "--method", "sim"]
        report("sim, cold", cold(sim))
        report("sim, cold, 1 process", cold(sim + ["--workers", "1"]))
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


def report(label: str, walls: list[float]) -> None:
    print(f"  {label:22s} wall median {statistics.median(walls):5.2f} s "
          f"(min {min(walls):.2f}, max {max(walls):.2f}, n={len(walls)})")


if __name__ == "__main__":
    main()

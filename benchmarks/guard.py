"""The cost of the default scorer's guard on the shipped families: planning time with and without.

    python benchmarks/guard.py [--families c-shapes,convex,...] [--seed 200] [--max-parts 12]
        [--repeats 2]

For one fresh assembly of each training family (``generate(family, --seed)``, a seed no model
was trained on; at most ``--max-parts`` parts), plans with the default method twice: the shipped
default scorer (``OperationPredictor.load(shipped, engine="auto")``: the cascade with its guard,
``rap.model.inference.cascade``) and the same cascade with its guard removed (``guard = None``),
each freshly loaded and with a fresh score cache (the same simulations in both), alternating
``--repeats`` times; the best time of each counts. Prints per assembly both times, their ratio,
whether the guard flagged the assembly and whether the two plans are the same (steps and R),
then ``guard cost: X`` (the summed times' ratio, with guard over without). CPU count and load
average are printed: read the ratio, not the seconds.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv=None) -> None:
    from rap.geometry.families import FAMILIES, generate
    from rap.model.inference.operations import OperationPredictor
    from rap.plan import plan
    from rap.plan.scoring.cache import ScoreCache

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--families", default=",".join(FAMILIES))
    ap.add_argument("--seed", type=int, default=200)
    ap.add_argument("--max-parts", type=int, default=12)
    ap.add_argument("--repeats", type=int, default=2)
    a = ap.parse_args(argv)
    shipped = ROOT / "rap" / "data" / "default_model.pt"
    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}", flush=True)
    total = {"guard": 0.0, "none": 0.0}
    for fam in a.families.split(","):
        asm = generate(fam, a.seed)
        if len(asm) > a.max_parts:
            continue
        best, plans, flagged = {}, {}, False
        for _ in range(a.repeats):
            for variant in ("none", "guard"):
                scorer = OperationPredictor.load(shipped, engine="auto")
                if variant == "none":
                    scorer.guard = None
                t = time.perf_counter()
                r = plan(asm, model=scorer, cache=ScoreCache())
                dt = time.perf_counter() - t
                best[variant] = min(best.get(variant, dt), dt)
                plans[variant] = ([(s.moving, s.fixed, s.direction) for s in r.steps], r.robustness)
                if variant == "guard":
                    flagged = r.stats.get("guard") is not None
        for k in total:
            total[k] += best[k]
        print(f"{asm.name:18s} {len(asm):2d} parts: without {best['none']:6.1f} s, with "
              f"{best['guard']:6.1f} s, ratio {best['guard'] / best['none']:.2f}; flagged "
              f"{flagged}; same plan {plans['guard'] == plans['none']}", flush=True)
    print(f"guard cost: {total['guard'] / total['none']:.2f} (summed best times, "
          f"load average {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()

"""Fit the shipped model's score bounds (``rap/data/score_bounds.json``) on the ``fresh`` set.

Split-conformal calibration (``rap.model.calibration.fit``): every operation of the AND/OR graph
of each ``fresh`` assembly (one seed >= 200 of each generated family, ``datasets/splits.json``),
its shipped-model expected score beside its simulated score, from the score tables of
``python -m research.search_validation --set fresh --trust none`` (cached in
reports/search-validation/fresh.pkl). The shipped model was never trained on these assemblies:
the script checks that neither their names nor their geometry hashes are among the checkpoint's
training assemblies, and refuses to fit otherwise.

    python -m research.search_validation --set fresh --trust none     # the tables, once
    python -m research.score_bounds_calibration [--bins 6] [--out rap/data/score_bounds.json]
    python -m research.score_bounds_calibration --dry-run            # the quantiles only

Prints the bins (edges, counts) and per bin the conformal margin ``q`` added to ``p`` at several
levels, with the leave-one-assembly-out coverage of the bounds at each level (each assembly's
operations bounded by a fit on the other nine). Writes the bounds with their provenance (the
model file's SHA-256, the set, its assemblies, the counts, the command). Cost: seconds (plus one
graph enumeration per assembly for the hash check).
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import sys
from pathlib import Path

import numpy as np

from rap.model.calibration import DEFAULT_BINS, DEFAULT_PATH, fit, min_count, save
from research.validation_tables import (ROOT, assemblies_of, model_of, problem_of,
                                        saved_tables)

LEVELS = (0.5, 0.9, 0.95, 0.99, 0.995, 0.999)


def training_overlap(names, model: Path) -> list[str]:
    """The names among ``names`` whose name or geometry hash is one of ``model``'s training
    assemblies (the checkpoint's ``assemblies`` list)."""
    import torch

    ck = torch.load(model, map_location="cpu", weights_only=False)
    trained_names, trained_hashes = set(), set()
    for a in ck.get("assemblies", []):
        trained_names.add(a["name"])
        h = a["geometry_hash"]
        trained_hashes.update(h if isinstance(h, list) else [h])
    return [n for n in names
            if n in trained_names or problem_of(n).assembly.geometry_hash in trained_hashes]


def pairs(tabs: dict, names) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(predicted, simulated, assembly index) over every operation of the named tables."""
    p, s, a = [], [], []
    for i, n in enumerate(names):
        keys = list(tabs[n]["truth"])
        p += [tabs[n]["pred"][k] for k in keys]
        s += [tabs[n]["truth"][k] for k in keys]
        a += [i] * len(keys)
    return np.clip(np.array(p), 0.0, 1.0), np.array(s), np.array(a)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", default="fresh", choices=("fresh",),
                    help="the calibration set (only the shipped model's validation set)")
    ap.add_argument("--bins", type=int, default=DEFAULT_BINS)
    ap.add_argument("--cache", type=Path, default=ROOT / "reports" / "search-validation")
    ap.add_argument("--out", type=Path, default=DEFAULT_PATH)
    ap.add_argument("--dry-run", action="store_true", help="print, write nothing")
    a = ap.parse_args()
    names = assemblies_of(a.set)
    tabs = saved_tables(a.cache, a.set, names)
    model = model_of(names[0])
    overlap = training_overlap(names, model)
    if overlap:
        sys.exit(f"{model.name} was trained on {', '.join(overlap)}: not a calibration set")
    print(f"none of the {len(names)} is among {model.name}'s training assemblies (names and "
          f"geometry hashes)")
    p, s, asm = pairs(tabs, names)
    digest = hashlib.sha256(model.read_bytes()).hexdigest()
    provenance = {
        "model": model.name, "model_sha256": digest,
        "calibration": f"{a.set} set: every operation of {len(names)} assemblies' AND/OR graphs "
                       f"(datasets/splits.json), none in the model's training data",
        "set": a.set, "assemblies": names, "assembly_count": len(names),
        "simulator": "SimParams() defaults, root seed 20190527, 100 trials an operation",
        "command": "python -m research.search_validation --set fresh --trust none && "
                   f"python -m research.score_bounds_calibration --bins {a.bins}",
        "date": datetime.date.today().isoformat()}
    bounds = fit(p, s, bins=a.bins, provenance=provenance)
    print(f"{a.set}: {len(names)} assemblies, {p.size} operations; model {model.name} "
          f"(sha256 {digest[:12]}); {len(bounds.counts)} bins")
    print(f"mean residual s - p {np.mean(s - p):+.4f}, mean |s - p| {np.mean(np.abs(s - p)):.4f}")
    edges = (0.0,) + bounds.edges + (1.0,)
    print(f"{'bin (p)':>15} {'n':>5} " + " ".join(f"{'q@' + str(lv):>8}" for lv in LEVELS))
    for i, n in enumerate(bounds.counts):
        qs = [bounds.margins(lv)[i] for lv in LEVELS]
        print(f"[{edges[i]:.3f},{edges[i + 1]:.3f}) {n:5d} "
              + " ".join(f"{'1 (n<' + str(min_count(lv)) + ')' if np.isinf(q) else f'{q:+.4f}':>8}"
                         for q, lv in zip(qs, LEVELS)))
    # leave-one-assembly-out: each assembly's operations against the other assemblies' fit
    cover = {lv: [] for lv in LEVELS}
    for i, n in enumerate(names):
        rest = fit(p[asm != i], s[asm != i], bins=a.bins)
        for lv in LEVELS:
            cover[lv].append(float(np.mean(s[asm == i] <= rest.upper(p[asm == i], lv) + 1e-9)))
    print("leave-one-assembly-out coverage of the operations (mean over assemblies, worst): "
          + ", ".join(f"{lv}: {np.mean(c):.3f} ({min(c):.3f})" for lv, c in cover.items()))
    if not a.dry_run:
        save(bounds, a.out)
        print(f"wrote {a.out} ({a.out.stat().st_size} bytes)")


if __name__ == "__main__":
    main()

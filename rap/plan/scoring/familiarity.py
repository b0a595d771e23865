"""Is an assembly far from what a CNN was trained on? The familiarity check of ``rap-farm plan``.

* ``familiarity_operations(problem)``: up to ``FAMILIARITY_OPERATIONS`` operations of the assembly,
  breadth first from the whole, free ones left out (the model never scores them:
  ``rap.plan.scoring.scorer``): what the statistic is computed on.
* ``model_familiarity(meta, geometry_hash, images)``: warnings (text) from the checkpoint's
  metadata (``OperationPredictor.meta``: its training assemblies and image statistics) and the rendered
  images of those operations (``OperationPredictor.images``): the assembly was in the training data, or
  its images look unlike the training images.
* ``guard_stats(scorer, problem)``: the plan's ``guard`` entry when the default scorer's guard
  (``rap.model.inference.cascade``) found the assembly unfamiliar and acted, else nothing.
* ``foreground_stats(images)``: the image statistics compared, with the definitions of
  ``rap.model.data.rows.image_stats`` (computed here without importing pyarrow).

Deterministic; no simulation. No ray, no torch.

Example::

    ops = familiarity_operations(problem)
    for note in model_familiarity(cnn.meta, problem.geometry_hash, cnn.images(problem, ops)):
        print("note:", note)
"""

from __future__ import annotations

import re

import numpy as np

from rap.operation import Operation
from rap.plan.problem import PlanningProblem

__all__ = ["familiarity_operations", "model_familiarity", "foreground_stats", "guard_stats",
           "FAMILIARITY_OPERATIONS"]

FAMILIARITY_OPERATIONS = 64  # operations whose images ``model_familiarity`` compares


def familiarity_operations(problem: PlanningProblem,
                           limit: int = FAMILIARITY_OPERATIONS) -> list[Operation]:
    """Up to ``limit`` operations of the assembly that are not free, breadth first from the whole
    (its candidates, then those of the subassemblies they leave, each subassembly once), looking
    at no more than ``4 * limit`` candidates (an assembly of parts lying apart offers free ones
    only): what ``model_familiarity`` is calibrated on, and operations a planner looks at anyway
    (candidates are memoised by the problem). Deterministic. Cost: the candidates of the
    subassemblies visited, typically a few."""
    out: list[Operation] = []
    queue, seen, head, looked = [problem.whole], set(), 0, 0
    while head < len(queue) and len(out) < limit and looked < 4 * limit:
        s = queue[head]
        head += 1
        if len(s) < 2 or s in seen:
            continue
        seen.add(s)
        for op in problem.candidates(s):
            looked += 1
            if not problem.is_free(op):  # free: 1 by geometry, never the model's (scorer)
                out.append(op)
            queue += [op.moving, op.fixed]
    return out[:limit]


def model_familiarity(meta: dict, geometry_hash: str, images: np.ndarray,
                      z_limit: float = 3.0, coarse_limit: float = 0.25) -> list[str]:
    """Warnings (text) when an assembly is far from what a CNN was trained on, from the
    checkpoint's metadata ``{"assemblies": [...], "image_stats": {...}}`` and the rendered images
    of the assembly's operations (``familiarity_operations``): per channel, the z-score of the
    mean foreground fraction against the training images, and the mean difference of the coarse
    8x8 foreground maps. Also says when the assembly itself was in the training data (estimates
    are optimistic). The limits sit above what the shipped model's own training assemblies give
    on ``FAMILIARITY_OPERATIONS`` operations each (at most z 1.9 and coarse 0.21 over its 334;
    tested). On the few candidates of the whole assembly alone the statistic is too noisy: 11 of
    them passed the limits there, a reference assembly among them."""
    notes = []
    trained = meta.get("assemblies") or []
    for a in trained:
        h = a.get("geometry_hash")
        if h == geometry_hash or (isinstance(h, list) and geometry_hash in h):
            notes.append(f"this assembly ({a.get('name')}) was in the model's training data: its "
                         f"predictions are not a test of generalisation")
    ref = meta.get("image_stats") or {}
    if len(images) and ref.get("foreground_mean") and ref.get("coarse_foreground") is not None:
        new = foreground_stats(np.asarray(images, dtype=np.uint8))
        z = [(m - rm) / rs if rs > 0 else 0.0 for m, rm, rs in
             zip(new["foreground_mean"], ref["foreground_mean"], ref["foreground_std"])]
        coarse = float(np.abs(np.asarray(new["coarse_foreground"])
                              - np.asarray(ref["coarse_foreground"])).mean())
        if max(abs(v) for v in z) > z_limit or coarse > coarse_limit:
            notes.append(f"this assembly looks unlike the model's training data (foreground "
                         f"z-scores {', '.join(f'{v:+.1f}' for v in z)}; coarse layout difference "
                         f"{coarse:.2f}; trained on {_trained_on(trained)}): expect "
                         f"more simulator fallbacks or less robust choices")
    return notes


def guard_stats(scorer, problem: PlanningProblem) -> dict:
    """``{"guard": ...}`` for a plan's stats when the scorer's model backend has a guard that
    found this assembly unfamiliar and acted (``rap.model.inference.cascade.CascadeScorer
    .guard_report``: the share of sampled operations whose descriptors lie far from the training
    rows, the threshold, and what was done), else ``{}``: a familiar assembly's plan is unchanged.
    The plan document writes it as ``guard`` (``rap.plan.report.result``). Only a planner that
    asked the model is reported (the verdict is cached per assembly: this costs nothing more).
    ``scorer``: a ``rap.plan.scoring.scorer.ScorerProtocol`` (its ``guard_report``)."""
    if not scorer.stats.cnn_batches:
        return {}
    got = scorer.guard_report(problem)
    return {"guard": got} if got else {}


def _trained_on(trained: list[dict]) -> str:
    names = [a.get("name", "?") for a in trained]
    if not names:
        return "unknown assemblies"
    if len(names) <= 8:
        return ", ".join(names)
    fams = sorted({re.sub(r"-s\d+$", "", n) if re.search(r"-s\d+$", n) else "reference"
                   for n in names})
    return f"{len(names)} assemblies of {len(fams)} kinds: {', '.join(fams)}"


def foreground_stats(images: np.ndarray) -> dict:
    """Of uint8 images [n, c, h, w]: per channel the mean foreground fraction (pixels > 0) and the
    coarse 8x8 mean foreground map; the definitions of ``rap.model.data.rows.image_stats``, which the
    checkpoint stores for its training images (computed here without importing pyarrow)."""
    k, c, hgt, wid = images.shape
    fg = images > 0
    return {"foreground_mean": fg.reshape(k, c, -1).mean(axis=2).mean(axis=0).tolist(),
            "coarse_foreground": fg.reshape(k, c, 8, hgt // 8, 8, wid // 8).mean(axis=(3, 5))
                                   .mean(axis=0).round(5).tolist()}

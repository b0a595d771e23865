"""The default scorer: a descriptor model screens operations, the CNN is asked where it is unsure.

``CascadeScorer(cnn, model)`` answers what ``OperationPredictor`` answers (the ``CnnBackend`` of
``rap.plan.scoring.scorer``: ``prob_high``, ``expected_score``, ``prob_high_and_expected``; and
``meta``, ``images``, ``cores_busy``, ``render_seconds`` for the plan command's familiarity check
and core sharing, passed to the CNN):

1. the batch's twelve geometric descriptors, exact, from one ``BatchDescriptors`` per assembly
   (kept for the eight most recent assemblies);
2. the descriptor model (``rap.model.inference.descriptor_model``; shipped: gradient-boosted
   trees): P(high) and the expected score of every operation;
3. the operations whose P(high) lies strictly inside ``band`` (``model.meta["band"]``) are
   rendered and scored by the CNN with the same descriptors, and take its numbers.

**The guard** (with ``NAME.guard.npz`` beside the descriptor model, ``guard_path``; shipped):
before it scores an assembly's first operation, the cascade measures how familiar the assembly is
to the trees: the descriptors of ``GUARD_OPERATIONS`` of its operations (breadth first from the
whole, free ones left out) against a sample of the training rows
(``rap.model.inference.descriptor_model.Familiarity``: the share of them whose mean distance to
their 5 nearest training rows exceeds that of 0.9 of the training rows). Beyond the stored
``share`` the assembly is
*unfamiliar*: every one of its operations is scored by the CNN too and takes the mean of the
trees' and the CNN's numbers (P(high) and expected score), and ``bounds`` answers with both fits'
bounds (``rap.model.calibration.MeanBounds`` of the CNN's own, ``rap.model.calibration.load()``,
and the trees'), through ``GuardedBounds``. Neither model decides alone where it is lost: on the
flagged assemblies of 6-11 parts measured (arches, a puzzle, tilings), the mean reached
0.935-1.000 of the optimum, where the CNN alone reached 0.888-1.000 and the larger of the two
(the action before) 0.735-1.000: on a flagged 11-part tiling the trees rate 88% of the sampled
operations 0.1 or more above the CNN, and the larger of the two followed them
(research/README.md, "The mean of the two"). ``verdict(problem)`` is judged once per geometry
(cached);
``guard_report(problem)`` is what a plan says when the guard acted (``rap.plan.scoring
.familiarity.guard_stats``: the plan's ``guard``). A familiar assembly is scored exactly as
without the guard (same numbers, same bounds). The active bounds follow the assembly this thread
scored last: a search scores before it bounds, in its own thread.

Results are deterministic and independent of how a caller batches the operations. The band
``(0.5, 0.5)`` (empty; the shipped one, chosen on the unseen set: the trees alone are within a
point of the CNN's accuracy, docs/MODEL.md) scores by the descriptors alone; ``(0, 1)`` is the CNN everywhere (with the
descriptors computed in batches). ``counts`` says how many operations each part answered.

Its ``bounds`` are the split-conformal score bounds fitted on the descriptor model's own
expected scores (``NAME.scorer.bounds.json``): a search over this scorer's numbers should bound
with them, not with the CNN's ``rap/data/score_bounds.json`` (``Scorer.bounds`` passes them on).

``load_default(path, ...)`` is what ``OperationPredictor.load(path, engine="auto")`` returns when
a descriptor model sits beside the checkpoint (``companion(path)``: ``NAME.scorer.npz`` next to
``NAME.pt``) and was fitted for it (the checkpoint's SHA-256 is in its meta); otherwise the CNN.

Cost: on the 22-brick wall's graph, a subassembly's operations a call, the descriptors and the
trees take 1/18 of the CNN's time (``python benchmarks/scorer.py``: 7,864 against 431 operations
a second, BLAS on one thread, a loaded 2-core machine), plus the CNN's for the operations in the
band; loading adds lightgbm's import (about a second with pandas). The guard: the descriptors of
64 operations and their distances to 60,000 reference rows in 14 size-free features, once an
assembly (tens of milliseconds); on an unfamiliar assembly the CNN's cost for every operation
(the CNN-alone search's time, under any time limit: the search's budget does not reach it).
Thread-safe: the CNN's lock serialises its forward passes; the descriptor tables are built under
a lock. No torch at import, no ray.
"""

from __future__ import annotations

import hashlib
import threading
from pathlib import Path
from typing import Sequence

import numpy as np

from rap.model.inference.descriptor_model import DescriptorModel, Familiarity
from rap.operation import Operation

__all__ = ["CascadeScorer", "GuardedBounds", "companion", "bounds_path", "guard_path",
           "load_default", "checkpoint_sha256", "GUARD_OPERATIONS", "guard_sample"]

#: operations of an assembly the guard measures (breadth first from the whole, free ones left out)
GUARD_OPERATIONS = 64


def companion(path: str | Path) -> Path:
    """Where the descriptor model of checkpoint ``path`` lives: ``NAME.scorer.npz`` beside it."""
    path = Path(path)
    return path.with_name(path.stem + ".scorer.npz")


def bounds_path(model_path: str | Path) -> Path:
    """The score bounds fitted for a descriptor model: ``NAME.bounds.json`` beside
    ``NAME.npz``."""
    model_path = Path(model_path)
    return model_path.with_name(model_path.name.removesuffix(".npz") + ".bounds.json")


def guard_path(model_path: str | Path) -> Path:
    """The guard's statistics for a descriptor model: ``NAME.guard.npz`` beside ``NAME.npz``."""
    model_path = Path(model_path)
    return model_path.with_name(model_path.name.removesuffix(".npz") + ".guard.npz")


def checkpoint_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


class CascadeScorer:
    """Descriptor network first, the CNN inside the band (module doc). ``cnn``: an
    ``OperationPredictor`` whose network takes the twelve descriptors or none; ``model``: a
    ``DescriptorModel``; ``band``: (lo, hi), default the model's; ``bounds``: the split-conformal
    score bounds (``rap.model.calibration.ScoreBounds``) fitted on this scorer's expected scores,
    which a search should use in place of the CNN's (None: not known)."""

    engine = "cascade"

    def __init__(self, cnn, model: DescriptorModel, band: tuple[float, float] | None = None,
                 bounds=None, guard: Familiarity | None = None):
        self.cnn = cnn
        self._bounds = bounds
        self.model = model
        self.guard = guard
        lo, hi = band if band is not None else model.meta.get("band", (0.5, 0.5))
        self.band = (float(lo), float(hi))
        self.counts = {"descriptors": 0, "cnn": 0}
        self.guarded = 0  # operations the guard sent to the CNN (counted in counts["cnn"] too)
        self._tables: dict = {}
        self._tables_lock = threading.Lock()
        self._verdicts: dict = {}
        self._local = threading.local()  # the verdict of the assembly this thread scored last
        self._unfamiliar_bounds = None  # (the CNN's, an unfamiliar one's), made on the first
        from rap.model.data.descriptors import DESCRIPTORS, columns

        names = tuple(getattr(cnn.predictor, "descriptors", ()) or ())
        self._cnn_columns = columns(names) if names else None
        if tuple(model.meta.get("descriptors", DESCRIPTORS)) != DESCRIPTORS:
            raise ValueError("the descriptor model must take rap.model.data.descriptors.DESCRIPTORS")

    # the guard ---------------------------------------------------------------------------
    @property
    def bounds(self):
        """The score bounds a search should use (module doc): the descriptor model's; with a
        guard, a ``GuardedBounds`` that answers with both models' bounds (``MeanBounds``) while
        the assembly this thread scores was found unfamiliar."""
        if self.guard is None:
            return self._bounds
        return GuardedBounds(self)

    @bounds.setter
    def bounds(self, value) -> None:
        self._bounds = value

    def verdict(self, problem) -> dict | None:
        """The guard's verdict on ``problem``'s assembly (module doc), judged once per geometry:
        ``{"unfamiliar", "outside", "share", "operations"}``; None without a guard."""
        if self.guard is None:
            return None
        h = problem.assembly.geometry_hash
        with self._tables_lock:
            got = self._verdicts.get(h)
        if got is None:
            ops = guard_sample(problem, GUARD_OPERATIONS)
            outside = self.guard.outside(self.descriptors(problem, ops)) if ops else 0.0
            got = {"unfamiliar": bool(ops) and outside > self.guard.share,
                   "outside": round(outside, 4), "share": self.guard.share,
                   "operations": len(ops)}
            with self._tables_lock:
                if len(self._verdicts) >= 64:
                    self._verdicts.pop(next(iter(self._verdicts)))
                self._verdicts[h] = got
        self._local.verdict = got
        return got

    def guard_report(self, problem) -> dict | None:
        """What a plan says of the guard: None when it did not act (no guard, or a familiar
        assembly), else the verdict and the action (every operation to the CNN, the CNN's
        bounds for the search)."""
        v = self.verdict(problem)
        if v is None or not v["unfamiliar"]:
            return None
        return {**v, "action": "every operation scored by the CNN as well, the mean of the "
                               "trees' and the CNN's numbers kept; the search bounds with both "
                               "models' score bounds"}

    def active_bounds(self):
        """The bounds of the assembly this thread scored last (``GuardedBounds``): on an
        unfamiliar one the CNN's shipped calibration (read once) with the descriptor model's
        (``MeanBounds``; with a trivial fit when the trees have none), else the descriptor
        model's (the CNN's when the trees have none)."""
        v = getattr(self._local, "verdict", None)
        unfamiliar = v is not None and v["unfamiliar"]
        if self._bounds is not None and not unfamiliar:
            return self._bounds
        if self._unfamiliar_bounds is None:
            from rap.model.calibration import MeanBounds, ScoreBounds, load

            cnn = load()
            trees = self._bounds if isinstance(self._bounds, ScoreBounds) else \
                ScoreBounds.trivial("the trees have no calibration")
            self._unfamiliar_bounds = (cnn, MeanBounds(cnn, trees))
        return self._unfamiliar_bounds[1 if unfamiliar else 0]

    @property
    def batch_first(self) -> bool:
        """Whether a caller that will score most of a set of operations should score them in one
        batch rather than a few at a time: true when the band is empty (no operation reaches the
        CNN), since the trees' cost is mostly per call (``python -m research.benchmarks.search``:
        a search's whole graph at once in 0.6 of the time of a batch per subassembly); false
        when the CNN may be asked (its cost is per operation: scoring only what is needed pays),
        as on the assembly this thread judged last when the guard found it unfamiliar (every
        operation to the CNN: on the issue's 10-part arch, 2,053 operations in one batch against
        1,293 asked lazily)."""
        v = getattr(self._local, "verdict", None)
        return self.band[0] >= self.band[1] and not (v is not None and v["unfamiliar"])

    # what the plan command reads of a CNN backend ------------------------------------------
    @property
    def predictor(self):
        return self.cnn.predictor

    @property
    def meta(self) -> dict:
        return self.cnn.meta

    def images(self, problem, ops: Sequence[Operation]) -> np.ndarray:
        return self.cnn.images(problem, ops)

    @property
    def cores_busy(self):
        return self.cnn.cores_busy

    @cores_busy.setter
    def cores_busy(self, fn) -> None:
        self.cnn.cores_busy = fn

    @property
    def render_seconds(self) -> float:
        return self.cnn.render_seconds

    # scoring -----------------------------------------------------------------------------
    def descriptors(self, problem, ops: Sequence[Operation]) -> np.ndarray:
        """The twelve descriptors of each operation, float32 [N, 12] (``BatchDescriptors``)."""
        from rap.model.data.batch_descriptors import BatchDescriptors

        h = problem.assembly.geometry_hash
        with self._tables_lock:
            tables = self._tables.get(h)
            if tables is None:
                if len(self._tables) >= 8:
                    self._tables.pop(next(iter(self._tables)))
                tables = self._tables[h] = BatchDescriptors(problem.assembly)
        return tables.of(ops)

    def prob_high_and_expected(self, problem, ops: Sequence[Operation]
                               ) -> tuple[np.ndarray, np.ndarray]:
        """(P(high), expected score) of each operation, float64 [N] each (module doc)."""
        ops = list(ops)
        if not ops:
            return np.zeros(0), np.zeros(0)
        d = self.descriptors(problem, ops)
        prob, expected = self.model.prob_high_and_expected(d)
        lo, hi = self.band
        verdict = self.verdict(problem)
        guarded = verdict is not None and verdict["unfamiliar"]
        if guarded:  # the guard: the CNN scores them all, the mean of the two is kept
            unsure = np.arange(len(ops))
            self.guarded += len(ops)
        else:
            unsure = np.flatnonzero((prob > lo) & (prob < hi))
        self.counts["descriptors"] += len(ops) - len(unsure)
        if len(unsure):
            self.counts["cnn"] += len(unsure)
            sub = [ops[i] for i in unsure]
            images = self.cnn.images(problem, sub)
            cd = None if self._cnn_columns is None else np.ascontiguousarray(
                d[unsure][:, self._cnn_columns])
            p, e = self.cnn.forward("prob_high_and_expected", images, cd)
            if guarded:
                p, e = (prob + p) / 2.0, (expected + e) / 2.0
            prob[unsure], expected[unsure] = p, e
        return prob, expected

    def prob_high(self, problem, ops: Sequence[Operation]) -> np.ndarray:
        return self.prob_high_and_expected(problem, ops)[0]

    def expected_score(self, problem, ops: Sequence[Operation]) -> np.ndarray:
        return self.prob_high_and_expected(problem, ops)[1]


def guard_sample(problem, limit: int) -> list[Operation]:
    """Up to ``limit`` operations that are not free, breadth first from the whole assembly (the
    sample of ``rap.plan.scoring.familiarity.familiarity_operations``, on the problem's own
    ``candidates`` and ``is_free``); deterministic."""
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
            if not problem.is_free(op):
                out.append(op)
            queue += [op.moving, op.fixed]
    return out[:limit]


class GuardedBounds:
    """Score bounds that follow the guard: every attribute (``upper``, ``calibrated``,
    ``perfect``, ``provenance``, ...) is that of ``cascade.active_bounds()``, the descriptor
    model's on a familiar assembly (unchanged numbers) and both models' (``MeanBounds``) on an
    unfamiliar one."""

    def __init__(self, cascade: CascadeScorer):
        self._cascade = cascade

    def __getattr__(self, name):
        return getattr(self._cascade.active_bounds(), name)


def load_default(path: str | Path, cnn) -> CascadeScorer | None:
    """A ``CascadeScorer`` over ``cnn`` (the loaded checkpoint ``path``) when a descriptor model
    fitted for this very checkpoint lies beside it (``companion``), else None."""
    model_path = companion(path)
    if not model_path.is_file():
        return None
    if DescriptorModel.read_meta(model_path).get("checkpoint_sha256") != checkpoint_sha256(path):
        return None  # fitted for another checkpoint: its trees are not even read
    model = DescriptorModel.load(model_path)
    bounds = None
    if bounds_path(model_path).is_file():
        from rap.model.calibration import load

        bounds = load(bounds_path(model_path))
    guard = Familiarity.load(guard_path(model_path)) if guard_path(model_path).is_file() else None
    return CascadeScorer(cnn, model, bounds=bounds, guard=guard)

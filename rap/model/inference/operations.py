"""The robustness CNN as a planner's scorer backend: render, describe, predict, in batches.

``OperationPredictor`` answers ``prob_high``, ``expected_score`` and ``prob_high_and_expected`` for a batch
of operations of one assembly (the ``CnnBackend`` of ``rap.plan.scoring.scorer``). It renders each
operation in the checkpoint's view (``rap.render.images.render_view``, 64 x 64), computes the
geometric descriptors when the network takes them (``rap.model.data.descriptors``; one
``DescriptorContext`` per assembly, kept for the eight most recent ones), and runs one of two
engines of the same network:

* ``rap.model.inference.torch_engine.TorchPredictor`` (torch);
* with ``OperationPredictor.load(..., engine="auto")`` on the CPU, the torch-free forward pass of
  ``rap.model.inference.numpy_engine`` when it runs the checkpoint exactly (no torch import: seconds saved for a
  one-off plan). Both give the same probabilities to float32 rounding.

A ``problem`` here is anything with an ``assembly`` (``rap.plan.problem.PlanningProblem``): this
module sits below the planners and imports none of them. Thread-safe: one forward pass at a time.
Cost: one rendering per operation and the engine's forward pass (figures in
``rap.model.inference.numpy_engine``). No ray; no torch at import.

Example::

    cnn = OperationPredictor.load("rap/data/default_model.pt", engine="auto")
    p_high, expected = cnn.prob_high_and_expected(problem, ops)   # float64 [N] each
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Callable, Protocol, Sequence

import numpy as np

from rap.assembly import Assembly
from rap.operation import Operation

__all__ = ["OperationPredictor", "HasAssembly", "IMAGE_SIZE", "SHARE_CHUNK", "SHIPPED_MODEL"]

#: the model shipped with the package (its card: docs/MODEL.md)
SHIPPED_MODEL = Path(__file__).resolve().parents[2] / "data" / "default_model.pt"

IMAGE_SIZE = 64
#: images per forward pass while ``OperationPredictor.cores_busy`` is consulted (a multiple of
#: ``rap.model.inference.numpy_engine.CHUNK``, so that the passes are the same)
SHARE_CHUNK = 256


class HasAssembly(Protocol):
    """What ``OperationPredictor`` reads of a planning problem."""

    assembly: Assembly


class OperationPredictor:
    """A loaded robustness CNN (``rap.model.inference.torch_engine.TorchPredictor``) plus the renderer.

    ``render(assembly, op, size=64) -> uint8 [2, 64, 64]`` defaults to
    ``rap.render.images.render_pair``.

    ``cores_busy``: optional ``() -> bool``, asked before each ``SHARE_CHUNK`` images of the numpy
    engine: while it says True the forward pass runs BLAS on one thread (threadpoolctl), leaving
    the other cores to processes that share the machine (``LocalSimulator.loading`` of
    ``rap.plan.scoring.local_simulator``: prestarted simulation workers; OpenBLAS's second thread spins
    between calls and starves them). Same results either way."""

    def __init__(self, predictor, render: Callable | None = None):
        self.predictor = predictor
        self._render = render
        self._lock = threading.Lock()  # one forward pass at a time (torch threads are shared)
        self.render_seconds = 0.0
        self.cores_busy: Callable[[], bool] | None = None
        self._threadpools = None
        self._contexts: dict = {}  # geometry hash -> DescriptorContext (a few recent assemblies)
        self._contexts_lock = threading.Lock()

    @classmethod
    def load(cls, path: str | Path, device: str = "cpu", engine: str = "torch",
             mirror: bool = False):
        """``engine``: ``"torch"`` (``rap.model.inference.torch_engine.TorchPredictor``);
        ``"cnn"``: the CNN alone, on the CPU ``rap.model.inference.numpy_engine``'s numpy forward
        pass when it runs this checkpoint exactly, else torch (both give the same probabilities
        to float32 rounding); ``"auto"``: the default scorer, the ``"cnn"`` predictor wrapped in a
        ``rap.model.inference.cascade.CascadeScorer`` when a descriptor model fitted for this
        checkpoint lies beside it (``cascade.companion``; the shipped model has one), else the
        same as ``"cnn"``. ``mirror``: average the network's outputs over each pair and its
        mirror image (twice the forward passes); a CNN option, so ``"auto"`` then gives the CNN
        alone."""
        if engine not in ("torch", "cnn", "auto"):
            raise ValueError(f"engine {engine!r}: torch, cnn or auto")
        cnn = None
        if engine in ("cnn", "auto") and str(device) == "cpu":
            from rap.model.inference.numpy_engine import load_numpy_predictor

            fast = load_numpy_predictor(path)
            if fast is not None:
                fast.mirror = bool(mirror)
                cnn = cls(fast)
        if cnn is None:
            from rap.model.inference.torch_engine import TorchPredictor

            cnn = cls(TorchPredictor.load(path, device=device, mirror=mirror))
        if engine == "auto" and not mirror:
            from rap.model.inference.cascade import load_default

            return load_default(path, cnn) or cnn
        return cnn

    @property
    def meta(self) -> dict:
        """What the checkpoint says about its training data (``model_familiarity``'s input)."""
        p = self.predictor
        return {"assemblies": p.assemblies, "image_stats": p.image_stats}

    def images(self, problem: HasAssembly, ops: Sequence[Operation]) -> np.ndarray:
        """The images the network takes (its checkpoint's view), uint8 [N, C, 64, 64]."""
        view = getattr(self.predictor, "view", "pair")
        if self._render is None:
            from rap.render.images import render_view

            self._render = lambda a, op, size: render_view(a, op, view, size=size)
        if not ops:
            from rap.render.images import view_channels

            return np.zeros((0, view_channels(view), IMAGE_SIZE, IMAGE_SIZE), np.uint8)
        return np.stack([np.asarray(self._render(problem.assembly, op, size=IMAGE_SIZE), np.uint8)
                         for op in ops])

    def descriptors(self, problem: HasAssembly, ops: Sequence[Operation]) -> np.ndarray | None:
        """The geometric descriptors the network takes (``rap.model.data.descriptors``), float32
        [N, k], or None when it takes images only. One NDBG per assembly, kept for the few most
        recent ones."""
        names = tuple(getattr(self.predictor, "descriptors", ()) or ())
        if not names:
            return None
        from rap.model.data.descriptors import DescriptorContext, columns, descriptors_for

        h = problem.assembly.geometry_hash
        with self._contexts_lock:  # its caches only grow: concurrent planners may share one
            ctx = self._contexts.get(h)
            if ctx is None:
                if len(self._contexts) >= 8:
                    self._contexts.pop(next(iter(self._contexts)))
                ctx = self._contexts[h] = DescriptorContext(problem.assembly)
        return np.ascontiguousarray(descriptors_for(ctx, ops)[:, columns(names)])

    def _inputs(self, problem: HasAssembly, ops: Sequence[Operation]):
        t = time.perf_counter()
        images = self.images(problem, ops)
        descriptors = self.descriptors(problem, ops)
        self.render_seconds += time.perf_counter() - t
        return images, descriptors

    def prob_high(self, problem: HasAssembly, ops: Sequence[Operation]) -> np.ndarray:
        images, descriptors = self._inputs(problem, ops)
        with self._lock:
            return self._forward("prob_high", images, descriptors)

    def expected_score(self, problem: HasAssembly, ops: Sequence[Operation]) -> np.ndarray:
        """The model's expected success rate of each operation (binomial head; P(high) for the
        class head, the best it knows)."""
        images, descriptors = self._inputs(problem, ops)
        with self._lock:
            return self._forward("expected_score", images, descriptors)

    def prob_high_and_expected(self, problem: HasAssembly, ops: Sequence[Operation]
                               ) -> tuple[np.ndarray, np.ndarray]:
        """``(prob_high, expected_score)`` of each operation from one rendering and one forward
        pass (a predictor without the combined call is asked twice)."""
        images, descriptors = self._inputs(problem, ops)
        with self._lock:
            if not hasattr(self.predictor, "prob_high_and_expected"):
                return (self._forward("prob_high", images, descriptors),
                        self._forward("expected_score", images, descriptors))
            return self._forward("prob_high_and_expected", images, descriptors)

    def forward(self, what: str, images: np.ndarray, descriptors: np.ndarray | None = None):
        """The network's ``what`` (``prob_high``, ``expected_score``, ``prob_high_and_expected``)
        on inputs already made (``images``, ``descriptors``), under the forward-pass lock."""
        with self._lock:
            return self._forward(what, images, descriptors)

    def _forward(self, what: str, images: np.ndarray, descriptors: np.ndarray | None = None):
        """The predictor's ``what`` on the images: float64 [N], or a tuple of them for a method
        that returns several (``prob_high_and_expected``)."""
        method = getattr(self.predictor, what)

        def run(lo: int, hi: int) -> tuple[np.ndarray, ...]:
            got = (method(images[lo:hi]) if descriptors is None
                   else method(images[lo:hi], descriptors[lo:hi]))
            return tuple(np.asarray(x, dtype=np.float64)
                         for x in (got if isinstance(got, tuple) else (got,)))

        busy = self.cores_busy
        if busy is None or getattr(self.predictor, "engine", None) != "numpy" or not len(images):
            parts = [run(0, len(images))]
        else:
            if self._threadpools is None:
                from threadpoolctl import ThreadpoolController

                self._threadpools = ThreadpoolController()
            parts = []
            for i in range(0, len(images), SHARE_CHUNK):
                if busy():
                    with self._threadpools.limit(limits=1, user_api="blas"):
                        parts.append(run(i, i + SHARE_CHUNK))
                else:
                    parts.append(run(i, i + SHARE_CHUNK))
        out = tuple(np.concatenate([p[j] for p in parts]) for j in range(len(parts[0])))
        return out if len(out) > 1 else out[0]

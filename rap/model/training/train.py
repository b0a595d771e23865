"""Training the robustness CNN on a rap-farm dataset (optionally leaving assemblies or families out).

Adam (AdamW with ``weight_decay``), learning rate ``lr``, constant or cosine-annealed per step.
The loss is the head's (``rap.model.network.heads``): the paper's class head with cross-entropy, class-
weighted by inverse class frequencies of the training rows (``w_c = N / (2 N_c)``,
``class_weighting="balanced"``; ``"none"`` for the plain loss), or the binomial head with the
binomial likelihood of the observed success counts. No resampling, so every row is seen once an
epoch. Augmentation ``hflip`` mirrors a pair left-right with probability 1/2 (seeded): exact for
this data, since the motion is normalised downward and the physics (no gravity, noise symmetric
about the path) is mirror-symmetric.

Calibration (``calibrate``): a seeded ``val_fraction`` of the training assemblies (``val_by=
"assemblies"``) or whole assemblies holding about that fraction of the rows (``"rows"``: one big
assembly cannot take a fifth of the corpus from training) is held out of training, and the
temperature that minimises the log loss of P(high) on their rows is stored with the model
(``rap.model.network.heads.fit_temperature``).

Reproducible on the CPU for a given seed (and thread count): the weights' initialisation and
dropout draw from a forked torch RNG seeded with ``seed``, shuffling, augmentation and the
validation split from ``numpy.random.default_rng(seed)``; the caller's global RNG state is left as
it was. ``store`` (a ``RowStore``) replaces reading the dataset for callers that train many
models on one dataset.

``train`` runs named steps: the training set (``rap.model.training.trainset``: rows in memory, hold-outs
checked, calibration assemblies taken out, the network's inputs, batches), the class weights and
the optimiser, the epoch state to resume from (``_resume``), one ``_train_epoch`` per epoch, then
calibration and the held-out metrics (``rap.model.evaluation.heldout``) and the provenance.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import torch

from rap import __version__
from rap.dataset import count_rows
from rap.errors import InputError, ParameterError
from rap.model.network import heads
from rap.model.network.checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from rap.model.network.cnn import ModelConfig, RobustnessCNN
from rap.model.data.rows import RowStore, assembly_summary, data_fingerprint, image_stats
from rap.model.evaluation.heldout import calibrate, holdout_metrics
from rap.model.inference.torch_engine import resolve_device
from rap.model.training.resume import capture, load_state, run_key, save_state
from rap.model.training.trainset import (check_holdouts, in_memory_store, training_batches,
                                training_selection, with_network_inputs)

__all__ = ["TrainConfig", "TrainResult", "train", "corpus_version"]


@dataclass(frozen=True)
class TrainConfig:
    """How to train. ``num_threads`` 0 leaves torch's thread count alone; ``max_rows`` > 0 trains
    on a seeded sample of that many training rows (ablations at a reduced budget)."""

    epochs: int = 8
    batch_size: int = 64
    seed: int = 0
    device: str = "auto"
    threshold: float = 0.95
    class_weighting: str = "balanced"
    augment: str = "none"  # "hflip" or "none"
    num_threads: int = 0
    max_memory_mb: float = 2048.0
    lr: float = 1e-3
    schedule: str = "constant"  # "constant" or "cosine"
    weight_decay: float = 0.0
    calibrate: bool = False
    val_fraction: float = 0.1
    val_by: str = "assemblies"  # the calibration split: that fraction of "assemblies" or of "rows"
    max_rows: int = 0

    def __post_init__(self):
        if self.epochs < 1 or self.batch_size < 1:
            raise InputError("epochs and batch size must be at least 1")
        if self.class_weighting not in ("balanced", "none"):
            raise InputError(f"class weighting {self.class_weighting!r}: balanced or none")
        if self.augment not in ("hflip", "none"):
            raise InputError(f"augment {self.augment!r}: hflip or none")
        if self.val_by not in ("assemblies", "rows"):
            raise InputError(f"val_by {self.val_by!r}: assemblies or rows")
        if self.schedule not in ("constant", "cosine"):
            raise InputError(f"schedule {self.schedule!r}: constant or cosine")
        if not (self.lr > 0 and self.weight_decay >= 0 and 0 < self.val_fraction < 1
                and self.max_rows >= 0):
            raise InputError("lr > 0, weight_decay >= 0, 0 < val_fraction < 1, max_rows >= 0")

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class TrainResult:
    """A trained network and the metadata its checkpoint carries."""

    model: RobustnessCNN
    threshold: float
    data_fingerprint: str
    assemblies: list
    image_stats: dict
    metrics: dict
    training: dict
    calibration: dict | None = None

    def save(self, path: str | Path) -> Path:
        return save_checkpoint(path, self.model, threshold=self.threshold,
                               data_fingerprint=self.data_fingerprint, assemblies=self.assemblies,
                               image_stats=self.image_stats, metrics=self.metrics,
                               training=self.training, calibration=self.calibration)


class _Threads:
    """Set torch's intra-op thread count for a block (0: leave it)."""

    def __init__(self, n: int):
        self.n = n

    def __enter__(self):
        self.old = torch.get_num_threads()
        if self.n:
            torch.set_num_threads(self.n)

    def __exit__(self, *exc):
        torch.set_num_threads(self.old)


def _lr_at(config: TrainConfig, step: int, total: int) -> float:
    if config.schedule == "constant":
        return config.lr
    return 0.5 * config.lr * (1.0 + math.cos(math.pi * min(step, total) / max(total, 1)))


def train(root: str | Path, *, holdout: str | None = None, holdout_family: str | None = None,
          model_config: ModelConfig = ModelConfig(), config: TrainConfig = TrainConfig(),
          on_step: Callable[[dict], None] | None = None, store: RowStore | None = None,
          command: str | None = None, init: str | Path | None = None,
          resume: str | Path | None = None) -> TrainResult:
    """Train on the dataset at ``root`` without the assembly ``holdout`` / the family
    ``holdout_family``; report metrics on what was held out.

    ``init``: start from this checkpoint's weights instead of a random initialisation (fine-tuning
    or training longer); its architecture must be ``model_config``'s. Its path and data
    fingerprint go into the provenance (``training["init"]``).

    A value that cannot be used raises ``ParameterError`` naming its parameter: ``holdout`` or
    ``holdout_family`` not in the dataset, ``init`` of another architecture, ``config``'s
    ``max_rows`` on a dataset too large for memory, ``device`` ``cuda`` without CUDA.

    ``resume``: a file for the run's epoch state (``rap.model.training.resume``), written after every
    epoch; a state there from this same run (same recipe, network, rows, hold-out, ``init``) is
    continued from, bit-identically on the same device; one from another run is replaced.
    ``training["resume"]`` says which (``from_epoch``, ``replaced``). The caller removes the file
    once the checkpoint is saved.

    ``on_step`` gets after every batch ``{"epoch", "epochs", "step", "steps", "loss", "accuracy"}``
    (running means over the epoch so far); before training, while the channels of a view that is
    not stored are rendered or the descriptors computed, ``{"task": "render VIEW" or "descriptors",
    "epoch": 1, "epochs": 1, "step": rows done, "steps": rows}``. ``command`` (the command line that asked for this
    training) is stored in the checkpoint's provenance with the corpus version (``corpus_version``).

    Example::

        result = train("datasets/corpus", holdout="hexagon", config=TrainConfig(epochs=2, seed=0))
        result.save("hexagon-out.pt")
    """
    root = str(Path(root).resolve())
    store = in_memory_store(root, store, config.max_memory_mb, config.max_rows)
    check_holdouts(root, store, holdout, holdout_family)
    init_ckpt = _init_checkpoint(init, model_config) if init is not None else None
    sel, val = training_selection(root, store, holdout, holdout_family, config.calibrate,
                                  config.val_fraction, config.val_by, config.seed)
    device = resolve_device(config.device)
    store = with_network_inputs(store, model_config, on_step)
    t0 = time.perf_counter()
    with _Threads(config.num_threads), \
            torch.random.fork_rng(devices=[device.index or 0] if device.type == "cuda" else []):
        torch.manual_seed(config.seed)
        rng = np.random.default_rng(config.seed)
        data, index = training_batches(root, sel, store, config.threshold, config.batch_size,
                                       config.max_memory_mb, config.max_rows, config.seed)
        counts = data.class_counts()
        weights = _class_weights(len(data), counts, config, model_config.head)
        fingerprint = store.fingerprint(index) if store is not None else data_fingerprint(sel)
        model = RobustnessCNN(model_config).to(device)
        if init_ckpt is not None:
            model.load_state_dict(init_ckpt.model.state_dict())
        opt = _optimizer(model, config)
        progress = _Progress(steps=-(-len(data) // config.batch_size))
        key = resumed = None
        if resume is not None:
            key = run_key(config.to_dict(), model_config.to_dict(), fingerprint, holdout,
                          holdout_family, _init_provenance(init_ckpt))
            resumed = _resume(resume, key, progress, model, opt, rng, device)
        w = torch.tensor(weights, dtype=torch.float32, device=device)
        while progress.epoch < config.epochs:
            _train_epoch(model, opt, data, rng, w, device, config, progress, on_step)
            if resume is not None:
                save_state(resume, capture(key, progress.epoch, progress.global_step,
                                           progress.train_seconds, model, opt, rng, device,
                                           progress.last))
        model.eval()
        n_trials = int(np.bincount(data.trials).argmax())
        last = progress.last
        metrics = {"train": {"loss": last["loss_sum"] / last["seen"],
                             "accuracy": last["hits"] / last["seen"],
                             "rows": len(data), "high_rows": int(counts[1]),
                             "samples_per_s": len(data) * config.epochs
                             / max(progress.train_seconds, 1e-9)}}
        calibration = (calibrate(model, root, val, device, store, config.threshold, n_trials)
                       if val else None)
        temperature = calibration["temperature"] if calibration else 1.0
        metrics.update(holdout_metrics(model, root, holdout, holdout_family, device, store,
                                       config.threshold, n_trials, temperature))
    stats = image_stats(data.image_batches())
    summary = (store.summary(index, config.threshold) if store is not None
               else assembly_summary(sel, config.threshold))
    training = {"config": config.to_dict(), "model_config": model_config.to_dict(),
                "dataset": root, "corpus": corpus_version(root, fingerprint),
                "holdout": holdout, "holdout_family": holdout_family,
                "class_counts": [int(c) for c in counts], "class_weights": weights,
                "trials": n_trials, "device": str(device), "command": command,
                "init": _init_provenance(init_ckpt), "resume": resumed,
                "seconds": time.perf_counter() - t0, "code_version": __version__,
                "torch_version": str(torch.__version__)}
    return TrainResult(model=model.cpu(), threshold=float(config.threshold),
                       data_fingerprint=fingerprint, assemblies=summary, image_stats=stats,
                       metrics=metrics, training=training, calibration=calibration)


# -- the steps of train(), in order -------------------------------------------------------------
def _class_weights(rows: int, counts, config: TrainConfig, head: str) -> list[float]:
    """The class head's loss weights ``N / (2 N_c)`` when balanced, else ones."""
    if config.class_weighting == "balanced" and head == "class":
        return [rows / (2 * c) if c else 1.0 for c in counts]
    return [1.0, 1.0]


def _optimizer(model: RobustnessCNN, config: TrainConfig) -> torch.optim.Optimizer:
    if config.weight_decay:
        return torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    return torch.optim.Adam(model.parameters(), lr=config.lr)


@dataclass
class _Progress:
    """Where a run stands: epochs done, optimiser steps, training seconds, and ``last``: the last
    epoch's running sums (``loss_sum``: loss times rows, ``hits``: correct predictions, ``seen``:
    rows), as the epoch state stores them."""

    steps: int  # batches an epoch
    epoch: int = 0
    global_step: int = 0
    train_seconds: float = 0.0
    last: dict = field(default_factory=lambda: {"loss_sum": 0.0, "hits": 0, "seen": 0})


def _resume(path: str | Path, key: str, progress: _Progress, model, opt, rng,
            device: torch.device) -> dict:
    """Continue from the epoch state at ``path`` when it is this run's (``key``): restores the
    weights, optimiser, random generators and ``progress``. Returns ``training["resume"]``."""
    state = load_state(path, key)
    resumed = {"path": str(path), "from_epoch": 0,
               "replaced": state is None and Path(path).exists()}
    if state is not None:
        state.restore(model, opt, rng, device)
        progress.epoch, progress.global_step = state.epoch, state.global_step
        progress.train_seconds = state.train_seconds
        progress.last = {k: state.last[k] for k in ("loss_sum", "hits", "seen")}
        resumed["from_epoch"] = state.epoch
    return resumed


def _train_epoch(model: RobustnessCNN, opt, data, rng: np.random.Generator, w: torch.Tensor,
                 device: torch.device, config: TrainConfig, progress: _Progress,
                 on_step: Callable[[dict], None] | None) -> None:
    """One epoch over ``data`` in the order ``rng`` shuffles it (mirrored pairs drawn from ``rng``
    too), one optimiser step a batch; ``progress`` advanced by one epoch."""
    head = model.config.head
    total = progress.steps * config.epochs
    model.train()
    loss_sum, hits, seen = 0.0, 0, 0
    te = time.perf_counter()
    for step, batch in enumerate(data.epoch(rng)):
        images, labels, successes, trials = batch[:4]
        d = torch.from_numpy(batch[4]).to(device) if len(batch) > 4 else None
        if config.augment == "hflip":
            flip = rng.random(len(images)) < 0.5
            images = np.where(flip[:, None, None, None], images[..., ::-1], images)
        for g in opt.param_groups:
            g["lr"] = _lr_at(config, progress.global_step, total)
        progress.global_step += 1
        x = torch.from_numpy(np.ascontiguousarray(images)).to(device)
        y = torch.from_numpy(labels).to(device)
        out = model(x, d)
        loss = heads.loss(out, head, labels=y, successes=torch.from_numpy(successes).to(device),
                          trials=torch.from_numpy(trials).to(device), class_weights=w)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        loss_sum += loss.item() * len(y)
        with torch.no_grad():
            ph = heads.prob_high(out.detach(), head, config.threshold, int(trials[0]))
        hits += int(((ph >= 0.5).long() == y).sum())
        seen += len(y)
        if on_step is not None:
            on_step({"epoch": progress.epoch + 1, "epochs": config.epochs, "step": step + 1,
                     "steps": progress.steps, "loss": loss_sum / seen, "accuracy": hits / seen})
    progress.train_seconds += time.perf_counter() - te
    progress.last = {"loss_sum": loss_sum, "hits": hits, "seen": seen}
    progress.epoch += 1


# -- provenance ----------------------------------------------------------------------------------
def _init_checkpoint(path: str | Path, model_config: ModelConfig) -> Checkpoint:
    """The checkpoint ``train(init=path)`` starts from; ``ParameterError`` (parameter ``init``)
    for another architecture."""
    ckpt = load_checkpoint(path)
    if ckpt.config != model_config:
        theirs, ours = ckpt.config.to_dict(), model_config.to_dict()  # a default may be left out
        diff = sorted(k for k in theirs.keys() | ours.keys() if theirs.get(k) != ours.get(k))
        raise ParameterError("init", Path(path), f"its network differs from this recipe's in "
                             f"{', '.join(diff)} (choose the recipe and options it was trained "
                             f"with)")
    return ckpt


def _init_provenance(ckpt: Checkpoint | None) -> dict | None:
    if ckpt is None:
        return None
    return {"path": ckpt.path, "data_fingerprint": ckpt.data_fingerprint,
            "command": ckpt.training.get("command")}


def corpus_version(root: str | Path, fingerprint: str) -> dict:
    """What a model was trained on, for its checkpoint: the dataset's directory name, rows, root
    seed, simulator parameters' fingerprint, the labelling code's version and the training rows'
    fingerprint (hex SHA-256 of their sorted keys and the dataset metadata)."""
    from rap.dataset import read_meta

    meta = read_meta(root)
    params_fp = None
    if meta is not None:
        try:
            from rap.sim.params import SimParams

            params_fp = SimParams.from_dict(dict(meta.params)).fingerprint()
        except (TypeError, ValueError):
            params_fp = None
    return {"name": Path(root).name, "rows": count_rows(root, unique=True),
            "root_seed": meta.root_seed if meta else None, "params_fingerprint": params_fp,
            "labelled_by": meta.code_version if meta else None,
            "schema_version": meta.schema_version if meta else None,
            "training_rows_fingerprint": fingerprint}

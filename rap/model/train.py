"""Training the robustness CNN on a rap-farm dataset (optionally leaving assemblies or families out).

Adam (AdamW with ``weight_decay``), learning rate ``lr``, constant or cosine-annealed per step.
The loss is the head's (``rap.model.heads``): the paper's class head with cross-entropy, class-
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
(``rap.model.heads.fit_temperature``).

Reproducible on the CPU for a given seed (and thread count): the weights' initialisation and
dropout draw from a forked torch RNG seeded with ``seed``, shuffling, augmentation and the
validation split from ``numpy.random.default_rng(seed)``; the caller's global RNG state is left as
it was. ``store`` (a ``RowStore``) replaces reading the dataset for callers that train many
models on one dataset.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import torch

from rap import __version__
from rap.dataset import count_rows, read_table
from rap.errors import InputError
from rap.model import heads
from rap.model.checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from rap.model.cnn import ModelConfig, RobustnessCNN
from rap.model.data import (InMemoryBatches, RowStore, Selection, assembly_summary,
                            data_fingerprint, image_stats, iter_rows, labels_of, make_batches,
                            select)
from rap.model.metrics import classification_metrics
from rap.model.predict import batch_outputs, resolve_device
from rap.model.resume import capture, load_state, run_key, save_state

__all__ = ["TrainConfig", "TrainResult", "train", "predict_selection", "dataset_assemblies",
           "dataset_families"]


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


def dataset_assemblies(root: str | Path) -> list[str]:
    """Sorted names of the assemblies present in a dataset."""
    col = read_table(root, columns=["assembly"]).column("assembly")
    return sorted(set(col.unique().to_pylist()))


def dataset_families(root: str | Path) -> dict[str, list[str]]:
    """Family -> sorted assembly names (``custom`` for rows without a family)."""
    t = read_table(root, columns=["assembly", "family"])
    out: dict[str, set] = {}
    for a, f in zip(t.column("assembly").to_pylist(), t.column("family").to_pylist()):
        out.setdefault(f or "custom", set()).add(a)
    return {f: sorted(v) for f, v in sorted(out.items())}


def predict_selection(model: RobustnessCNN, sel: Selection, device: torch.device,
                      batch_size: int = 512, store: RowStore | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(scores, trials, raw outputs [N, k]) of every row of ``sel``, in dataset order."""
    model.eval()
    scores, trials, outs = [], [], []
    if store is not None:
        idx = store.index(sel)
        for s in range(0, len(idx), batch_size):
            rows = idx[s:s + batch_size]
            scores.append(store.scores[rows])
            trials.append(store.trials[rows])
            outs.append(batch_outputs(model, store.images[rows], device,
                                      None if store.descriptors is None
                                      else store.descriptors[rows]))
    else:
        for images, sc, tr in iter_rows(sel, batch_size=batch_size,
                                        columns=("score", "trials", "image")):
            scores.append(sc)
            trials.append(tr)
            outs.append(batch_outputs(model, images, device))
    if not scores:
        k = 2 if model.config.head == "class" else 1
        return np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, k))
    return np.concatenate(scores), np.concatenate(trials), np.concatenate(outs)


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


def _split_validation(names: list[str], fraction: float, seed: int,
                      rows: dict[str, int] | None = None) -> list[str]:
    """The assemblies held out for calibration, seeded: a ``fraction`` of ``names`` (at least one,
    never all); or, given ``rows`` (assembly -> rows), whole assemblies taken in a seeded order
    while their rows fit in ``fraction`` of all rows (an assembly larger than what is left is
    skipped, so one big assembly does not take a tenth of the corpus from training; the
    smallest when none fits). O(n log n) in the assemblies."""
    if len(names) < 3:
        return []
    rng = np.random.default_rng([seed, 7])
    if rows is None:
        k = min(len(names) - 1, max(1, round(fraction * len(names))))
        return sorted(rng.choice(sorted(names), size=k, replace=False).tolist())
    budget = fraction * sum(rows[n] for n in names)
    taken, total = [], 0
    for n in rng.permutation(sorted(names)).tolist():
        if total + rows[n] <= budget:
            taken.append(n)
            total += rows[n]
    if not taken:
        taken = [min(sorted(names), key=lambda n: rows[n])]
    return sorted(taken)


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
    or training longer); its architecture must be ``model_config``'s (else ``InputError``). Its
    path and data fingerprint go into the provenance (``training["init"]``).

    ``resume``: a file for the run's epoch state (``rap.model.resume``), written after every
    epoch; a state there from this same run (same recipe, network, rows, hold-out, ``init``) is
    continued from, bit-identically on the same device; one from another run is replaced.
    ``training["resume"]`` says which (``from_epoch``, ``replaced``). The caller removes the file
    once the checkpoint is saved.

    ``on_step`` gets after every batch ``{"epoch", "epochs", "step", "steps", "loss", "accuracy"}``
    (running means over the epoch so far); before training, while the channels of a view that is
    not stored are rendered or the descriptors computed, ``{"task": "render VIEW" or "descriptors",
    "epoch": 1, "epochs": 1, "step": rows done, "steps": rows}``. ``command`` (the command line that asked for this
    training) is stored in the checkpoint's provenance with the corpus version (``corpus_version``).
    """
    root = str(Path(root).resolve())
    if store is None and Path(root).is_dir():
        from rap.dataset import IMAGE_BYTES

        n_all = select(root).count()
        if n_all * (IMAGE_BYTES + 256) <= config.max_memory_mb * 2 ** 20:
            store = RowStore(root)  # the whole dataset fits: one read, index-based selections
        elif config.max_rows:
            raise InputError(f"--max-rows needs the dataset in memory ({n_all} rows exceed "
                             f"max_memory_mb {config.max_memory_mb:.0f})")
    if store is not None:
        names = sorted(set(store.assembly.tolist()))
        families = sorted(set(store.family.tolist()))
    else:
        names = dataset_assemblies(root)
        families = list(dataset_families(root)) if holdout_family else []
    if holdout is not None and holdout not in names:
        raise InputError(f"--holdout {holdout}: no such assembly in {root} "
                         f"(has: {', '.join(names)})")
    if holdout_family is not None and holdout_family not in families:
        raise InputError(f"--holdout-family {holdout_family}: no such family in {root} "
                         f"(has: {', '.join(families)})")
    init_ckpt = _init_checkpoint(init, model_config) if init is not None else None
    exclude = (holdout,) if holdout else ()
    exclude_families = (holdout_family,) if holdout_family else ()
    sel = select(root, exclude=exclude, exclude_families=exclude_families)
    val: list[str] = []
    if config.calibrate:
        rows = _rows_per_assembly(sel, store)
        val = _split_validation(sorted(rows), config.val_fraction, config.seed,
                                rows if config.val_by == "rows" else None)
        sel = select(root, exclude=exclude + tuple(val), exclude_families=exclude_families)
    device = resolve_device(config.device)
    head = model_config.head
    if model_config.view != "pair":
        if store is None:
            raise InputError(f"view {model_config.view!r} needs the dataset in memory "
                             f"(raise max_memory_mb)")
        rendering = None
        if on_step is not None:
            def rendering(done: int, total: int) -> None:
                on_step({"task": f"render {model_config.view}", "epoch": 1, "epochs": 1,
                         "step": done, "steps": total})
        store = store.view(model_config.view, rendering)
    if model_config.descriptors:
        if store is None:
            raise InputError("a network with descriptors needs the dataset in memory "
                             "(raise max_memory_mb)")
        describing = None
        if on_step is not None:
            def describing(done: int, total: int) -> None:
                on_step({"task": "descriptors", "epoch": 1, "epochs": 1, "step": done,
                         "steps": total})
        store = store.with_descriptors(model_config.descriptors, describing)
    t0 = time.perf_counter()
    with _Threads(config.num_threads), \
            torch.random.fork_rng(devices=[device.index or 0] if device.type == "cuda" else []):
        torch.manual_seed(config.seed)
        rng = np.random.default_rng(config.seed)
        if store is not None:
            index = store.index(sel)
            if config.max_rows and len(index) > config.max_rows:
                index = np.sort(np.random.default_rng([config.seed, 11]).choice(
                    index, size=config.max_rows, replace=False))
            if len(index) == 0:
                raise InputError(f"{root}: no training rows selected")
            data = InMemoryBatches.from_store(store, index, config.threshold, config.batch_size)
        else:
            index = None
            data = make_batches(sel, config.threshold, config.batch_size, config.max_memory_mb)
        counts = data.class_counts()
        if config.class_weighting == "balanced" and head == "class":
            weights = [len(data) / (2 * c) if c else 1.0 for c in counts]
        else:
            weights = [1.0, 1.0]
        fingerprint = store.fingerprint(index) if store is not None else data_fingerprint(sel)
        model = RobustnessCNN(model_config).to(device)
        if init_ckpt is not None:
            model.load_state_dict(init_ckpt.model.state_dict())
        if config.weight_decay:
            opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
        else:
            opt = torch.optim.Adam(model.parameters(), lr=config.lr)
        w = torch.tensor(weights, dtype=torch.float32, device=device)
        steps = -(-len(data) // config.batch_size)
        total = steps * config.epochs
        train_seconds = 0.0
        global_step = 0
        first_epoch, resumed = 0, None
        loss_sum, hits, seen = 0.0, 0, 0
        if resume is not None:
            key = run_key(config.to_dict(), model_config.to_dict(), fingerprint, holdout,
                          holdout_family, _init_provenance(init_ckpt))
            state = load_state(resume, key)
            resumed = {"path": str(resume), "from_epoch": 0,
                       "replaced": state is None and Path(resume).exists()}
            if state is not None:
                state.restore(model, opt, rng, device)
                first_epoch, global_step = state.epoch, state.global_step
                train_seconds = state.train_seconds
                loss_sum, hits, seen = state.last["loss_sum"], state.last["hits"], state.last["seen"]
                resumed["from_epoch"] = state.epoch
        for epoch in range(first_epoch, config.epochs):
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
                    g["lr"] = _lr_at(config, global_step, total)
                global_step += 1
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
                    on_step({"epoch": epoch + 1, "epochs": config.epochs, "step": step + 1,
                             "steps": steps, "loss": loss_sum / seen, "accuracy": hits / seen})
            train_seconds += time.perf_counter() - te
            if resume is not None:
                save_state(resume, capture(key, epoch + 1, global_step, train_seconds, model, opt,
                                           rng, device, {"loss_sum": loss_sum, "hits": hits,
                                                         "seen": seen}))
        model.eval()
        n_trials = int(np.bincount(data.trials).argmax())
        metrics = {"train": {"loss": loss_sum / seen, "accuracy": hits / seen,
                             "rows": len(data), "high_rows": int(counts[1]),
                             "samples_per_s": len(data) * config.epochs / max(train_seconds, 1e-9)}}
        calibration = None
        if val:
            vsel = select(root, include=tuple(val))
            scores, trials, outs = predict_selection(model, vsel, device, store=store)
            temp = heads.fit_temperature(outs, head, labels_of(scores, config.threshold),
                                         config.threshold, n_trials)
            calibration = {"temperature": temp, "assemblies": val, "rows": int(len(scores))}
        temperature = calibration["temperature"] if calibration else 1.0
        held = [(holdout, select(root, include=(holdout,)))] if holdout else []
        if holdout_family:
            held.append((holdout_family, select(root, families=(holdout_family,))))
        for name, hsel in held:
            scores, trials, outs = predict_selection(model, hsel, device, store=store)
            probs = heads.prob_high_np(outs, head, config.threshold, n_trials, temperature)
            metrics["holdout"] = {"assembly": name, "family": holdout_family,
                                  **classification_metrics(labels_of(scores, config.threshold),
                                                           probs, successes_of(scores, trials),
                                                           trials, config.threshold)}
            if store is not None:
                hidx = store.index(hsel)
                metrics["holdout"]["per_assembly"] = per_assembly_metrics(
                    store.assembly[hidx], scores, trials, probs, config.threshold)
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


def _init_checkpoint(path: str | Path, model_config: ModelConfig) -> Checkpoint:
    """The checkpoint ``train(init=path)`` starts from; ``InputError`` for another architecture."""
    ckpt = load_checkpoint(path)
    if ckpt.config != model_config:
        theirs = ckpt.config.to_dict()
        diff = sorted(k for k, v in model_config.to_dict().items() if theirs.get(k) != v)
        raise InputError(f"--init {path}: its network differs from this recipe's in "
                         f"{', '.join(diff)} (choose the recipe and options it was trained with)")
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


def _rows_per_assembly(sel: Selection, store: RowStore | None) -> dict[str, int]:
    """Assembly name -> rows in the selection (from ``store`` when given)."""
    if store is None:
        return {a["name"]: a["rows"] for a in assembly_summary(sel, 0.95)}
    names, counts = np.unique(store.assembly[store.index(sel)], return_counts=True)
    return {str(a): int(c) for a, c in zip(names, counts)}


def successes_of(scores: np.ndarray, trials: np.ndarray) -> np.ndarray:
    return np.rint(np.asarray(scores) * np.asarray(trials)).astype(np.int64)


def per_assembly_metrics(names: np.ndarray, scores: np.ndarray, trials: np.ndarray,
                         probs: np.ndarray, threshold: float) -> dict:
    """Per assembly of a held-out set: rows, accuracy and the noise ceiling."""
    out = {}
    for name in sorted(set(names.tolist())):
        m = names == name
        out[name] = classification_metrics(labels_of(scores[m], threshold), probs[m],
                                           successes_of(scores[m], trials[m]), trials[m],
                                           threshold, reliability=False)
    return out

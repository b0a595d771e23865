"""A trained network on rows it did not train on: predictions, calibration, held-out metrics.

The last steps of ``rap.model.training.train.train``, over plain values:

* ``predict_selection(model, sel, device, store=None)``: the scores, trials and raw outputs of every
  row of a selection, in dataset order (from an in-memory ``RowStore`` when given, else streamed).
* ``calibrate(...)``: the temperature that minimises the log loss of P(high) on the calibration
  assemblies' rows (``rap.model.network.heads.fit_temperature``).
* ``holdout_metrics(...)``: accuracy, per-class accuracy, ECE and the noise ceiling of the held-out
  assembly or family (``rap.model.evaluation.metrics.classification_metrics``), and per assembly.

Cost: one forward pass over the selected rows (``batch_size`` at a time). The model is put in
evaluation mode; nothing is trained.
"""

from __future__ import annotations

import numpy as np
import torch

from rap.model.network import heads
from rap.model.network.cnn import RobustnessCNN
from rap.model.data.rows import RowStore, Selection, iter_rows, labels_of, select
from rap.model.evaluation.metrics import classification_metrics
from rap.model.inference.torch_engine import batch_outputs

__all__ = ["predict_selection", "calibrate", "holdout_metrics", "per_assembly_metrics",
           "successes_of"]


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


def calibrate(model: RobustnessCNN, root: str, val: list[str], device: torch.device,
              store: RowStore | None, threshold: float, n_trials: int) -> dict:
    """``{"temperature", "assemblies", "rows"}``: the calibration temperature of ``model`` fitted
    on the rows of the assemblies ``val`` of the dataset at ``root``."""
    scores, trials, outs = predict_selection(model, select(root, include=tuple(val)), device,
                                             store=store)
    temp = heads.fit_temperature(outs, model.config.head, labels_of(scores, threshold),
                                 threshold, n_trials)
    return {"temperature": temp, "assemblies": val, "rows": int(len(scores))}


def holdout_metrics(model: RobustnessCNN, root: str, holdout: str | None,
                    holdout_family: str | None, device: torch.device, store: RowStore | None,
                    threshold: float, n_trials: int, temperature: float) -> dict:
    """``{"holdout": metrics}`` of the held-out assembly, else of the held-out family (the family's
    when both are given, as it is computed last); ``{}`` when nothing was held out. With ``store``,
    also ``per_assembly`` metrics."""
    held = [(holdout, select(root, include=(holdout,)))] if holdout else []
    if holdout_family:
        held.append((holdout_family, select(root, families=(holdout_family,))))
    out: dict = {}
    for name, hsel in held:
        scores, trials, outs = predict_selection(model, hsel, device, store=store)
        probs = heads.prob_high_np(outs, model.config.head, threshold, n_trials, temperature)
        out["holdout"] = {"assembly": name, "family": holdout_family,
                          **classification_metrics(labels_of(scores, threshold), probs,
                                                   successes_of(scores, trials), trials,
                                                   threshold)}
        if store is not None:
            hidx = store.index(hsel)
            out["holdout"]["per_assembly"] = per_assembly_metrics(
                store.assembly[hidx], scores, trials, probs, threshold)
    return out


def successes_of(scores: np.ndarray, trials: np.ndarray) -> np.ndarray:
    """Successes from success rates and trial counts (rounded to the nearest integer)."""
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

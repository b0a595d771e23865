"""What a training run learns from: its rows, its held-out and calibration assemblies, its inputs.

The first steps of ``rap.model.training.train.train``, over plain values:

* ``in_memory_store``: the whole dataset read into memory (a ``RowStore``) when it fits in the
  memory budget, else None (the rows are streamed);
* ``check_holdouts``: the held-out assembly or family must be in the dataset (``ParameterError``);
* ``training_selection``: the rows without what is held out, and the calibration assemblies
  (``split_validation``: seeded, by count of assemblies or by rows) taken out too;
* ``with_network_inputs``: the channels of the network's view rendered and its geometric
  descriptors computed, for a store;
* ``training_batches``: the training rows in batches (in memory or streamed), optionally a seeded
  sample of ``max_rows``.

``dataset_assemblies`` and ``dataset_families`` list what a dataset holds. Deterministic for a
given seed. Cost: one read of the dataset (or of its assembly column), and rendering a view that
is not stored or computing descriptors, once per row.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from rap.dataset import read_table
from rap.errors import InputError, ParameterError
from rap.model.network.cnn import ModelConfig
from rap.model.data.rows import (InMemoryBatches, RowStore, Selection, assembly_summary, make_batches,
                            select)

__all__ = ["dataset_assemblies", "dataset_families", "split_validation", "in_memory_store",
           "check_holdouts", "training_selection", "with_network_inputs", "training_batches",
           "rows_per_assembly"]


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



def split_validation(names: list[str], fraction: float, seed: int,
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



def in_memory_store(root: str, store: RowStore | None, max_memory_mb: float,
                    max_rows: int = 0) -> RowStore | None:
    """``store``, else the whole dataset read into memory when it fits in ``max_memory_mb`` (one
    read, index-based selections), else None (streamed; ``ParameterError`` (parameter
    ``max_rows``) when ``max_rows`` asks for a sample, which needs the rows in memory)."""
    if store is None and Path(root).is_dir():
        from rap.dataset import IMAGE_BYTES

        n_all = select(root).count()
        if n_all * (IMAGE_BYTES + 256) <= max_memory_mb * 2 ** 20:
            store = RowStore(root)
        elif max_rows:
            raise ParameterError("max_rows", max_rows, f"needs the dataset in memory ({n_all} rows "
                                 f"exceed max_memory_mb {max_memory_mb:.0f})")
    return store


def check_holdouts(root: str, store: RowStore | None, holdout: str | None,
                    holdout_family: str | None) -> None:
    """``ParameterError`` (parameter ``holdout`` or ``holdout_family``) for a held-out assembly or
    family that the dataset does not have."""
    if store is not None:
        names = sorted(set(store.assembly.tolist()))
        families = sorted(set(store.family.tolist()))
    else:
        names = dataset_assemblies(root)
        families = list(dataset_families(root)) if holdout_family else []
    if holdout is not None and holdout not in names:
        raise ParameterError("holdout", holdout, f"no such assembly in {root} "
                             f"(has: {', '.join(names)})", quote=False)
    if holdout_family is not None and holdout_family not in families:
        raise ParameterError("holdout_family", holdout_family, f"no such family in {root} "
                             f"(has: {', '.join(families)})", quote=False)


def training_selection(root: str, store: RowStore | None, holdout: str | None,
                       holdout_family: str | None, calibrate: bool = False,
                       val_fraction: float = 0.1, val_by: str = "assemblies", seed: int = 0
                       ) -> tuple[Selection, list[str]]:
    """(the training rows' selection, the calibration assemblies taken out of it: ``[]`` unless
    ``calibrate``; ``split_validation`` of ``val_fraction`` of the assemblies or, ``val_by="rows"``,
    of the rows)."""
    from rap.geometry.families import HELD_OUT

    exclude = (holdout,) if holdout else ()
    # the held-out shape kinds (rap.geometry.families.unseen) never enter a training set
    exclude_families = ((holdout_family,) if holdout_family else ()) + tuple(sorted(HELD_OUT))
    sel = select(root, exclude=exclude, exclude_families=exclude_families)
    val: list[str] = []
    if calibrate:
        rows = rows_per_assembly(sel, store)
        val = split_validation(sorted(rows), val_fraction, seed, rows if val_by == "rows" else None)
        sel = select(root, exclude=exclude + tuple(val), exclude_families=exclude_families)
    return sel, val


def with_network_inputs(store: RowStore | None, model_config: ModelConfig,
                        on_step: Callable[[dict], None] | None = None) -> RowStore | None:
    """The store with the channels of the network's view and its descriptors (rendered or
    computed now, reported to ``on_step``); ``InputError`` when they need a store and there is
    none."""
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
    return store


def training_batches(root: str, sel: Selection, store: RowStore | None, threshold: float,
                     batch_size: int, max_memory_mb: float, max_rows: int = 0, seed: int = 0):
    """(the batches of the training rows, their index in ``store`` or None when streamed); with
    ``max_rows``, a sample of that many rows seeded by ``seed``."""
    if store is None:
        return make_batches(sel, threshold, batch_size, max_memory_mb), None
    index = store.index(sel)
    if max_rows and len(index) > max_rows:
        index = np.sort(np.random.default_rng([seed, 11]).choice(index, size=max_rows,
                                                                 replace=False))
    if len(index) == 0:
        raise InputError(f"{root}: no training rows selected")
    return InMemoryBatches.from_store(store, index, threshold, batch_size), index



def rows_per_assembly(sel: Selection, store: RowStore | None) -> dict[str, int]:
    """Assembly name -> rows in the selection (from ``store`` when given)."""
    if store is None:
        return {a["name"]: a["rows"] for a in assembly_summary(sel, 0.95)}
    names, counts = np.unique(store.assembly[store.index(sel)], return_counts=True)
    return {str(a): int(c) for a, c in zip(names, counts)}

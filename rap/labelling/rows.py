"""Labelling rows without Ray: the simulator and renderer by import path, and one batch's rows.

``label_rows`` is what a simulation actor (``rap.farm.actors.SimWorker``) runs per task and what
``scripts/label_burst.py`` runs in a plain process pool on machines without Ray: one code path, so a
row does not depend on the executor. A label depends only on the operation's seed.
"""

from __future__ import annotations

import importlib
import json
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
import pyarrow as pa

from rap import __version__
from rap.dataset import IMAGE_SIZE, SCHEMA
from rap.operation import Operation, subset_key

__all__ = ["Backend", "resolve", "params_json", "label_rows", "WIRE_SCHEMA", "rows_table",
           "dataset_table"]

# A batch's rows as they travel from a worker: ``SCHEMA`` with the image nullable (None when
# images were not asked for) and each operation's simulator seconds.
WIRE_SCHEMA = pa.schema([f.with_nullable(True) if f.name == "image" else f for f in SCHEMA]
                        + [pa.field("seconds", pa.float64(), nullable=False)],
                        metadata=SCHEMA.metadata)


@dataclass(frozen=True)
class Backend:
    """Import paths (``module:attr``) of the simulator and the renderer used by the workers.

    ``simulate(assembly, operation, params, rng) -> SimResult(successes, trials, score, seconds)``;
    ``render(assembly, operation, params=..., size=...) -> uint8 [2, size, size]``;
    ``warm_up() -> seconds`` runs once when the actor starts (empty: none), so that loading the
    compiled simulator is not charged to the first batch.
    """

    simulate: str = "rap.sim.simulator:simulate"
    render: str = "rap.render.images:render_pair"
    warm_up: str = "rap.sim.simulator:warm_up"


def resolve(path: str) -> Callable:
    """The object at ``module:attr``."""
    mod, _, attr = path.partition(":")
    obj: Any = importlib.import_module(mod)
    for a in attr.split("."):
        obj = getattr(obj, a)
    return obj


def params_json(params: Any) -> str:
    """Canonical JSON text of simulator parameters (stored in every row)."""
    return json.dumps(params.to_dict(), sort_keys=True, separators=(",", ":"))


def label_rows(assembly: Any, operations: Sequence[Operation], keys: Sequence[str],
               seeds: Sequence[int], params: Any, params_json: str, *, simulate: Callable,
               render: Callable | None, node: str, assembly_name: str | None = None,
               geometry_hash: str | None = None) -> tuple[list[dict], float, float]:
    """Simulate (and render, when ``render`` is given) each operation with its own seeded rng.

    Returns the rows in ``rap.dataset.SCHEMA`` (``image`` None without ``render``), in input order,
    with the seconds spent in ``simulate`` and in ``render``. O(len(operations)) simulations.
    """
    name = assembly_name or assembly.name
    gh = geometry_hash or assembly.geometry_hash
    rows, sim_s, render_s = [], 0.0, 0.0
    for op, key, seed in zip(operations, keys, seeds):
        t = time.perf_counter()
        res = simulate(assembly, op, params, np.random.default_rng(seed))
        t1 = time.perf_counter()
        sim_s += t1 - t
        image = None
        if render is not None:
            pair = render(assembly, op, params=params, size=IMAGE_SIZE)
            image = np.ascontiguousarray(pair, np.uint8).tobytes()
            render_s += time.perf_counter() - t1
        rows.append({
            "key": key,
            "assembly": name,
            "geometry_hash": gh,
            "subassembly": subset_key(op.subassembly),
            "moving": subset_key(op.moving),
            "fixed": subset_key(op.fixed),
            "direction_x": float(op.direction[0]),
            "direction_y": float(op.direction[1]),
            "score": float(res.score),
            "successes": int(res.successes),
            "trials": int(res.trials),
            "image": image,
            "seed": int(seed),
            "params": params_json,
            "code_version": __version__,
            "node": node,
            "family": getattr(assembly, "family", "custom"),
            "direction_index": int(getattr(op, "direction_index", 0)),
            "seconds": float(getattr(res, "seconds", t1 - t)),
        })
    return rows, sim_s, render_s


def rows_table(rows: Sequence[dict]) -> pa.Table:
    """``label_rows``' rows as one table in ``WIRE_SCHEMA``: built where the rows are made (the
    worker), so that the driver handles a batch as a few columns, not as dicts. O(rows)."""
    cols = {f.name: pa.array([r[f.name] for r in rows], type=f.type) for f in WIRE_SCHEMA}
    return pa.Table.from_pydict(cols, schema=WIRE_SCHEMA)


def dataset_table(wire: pa.Table) -> pa.Table:
    """The dataset's columns (``SCHEMA``) of a wire table whose rows all have images; zero-copy."""
    return pa.Table.from_arrays([wire.column(f.name) for f in SCHEMA], schema=SCHEMA)

"""The orchestration layer: the only package that imports ``ray`` (``selection`` and ``rows`` do not).

* ``rap.farm.runtime``: start an embedded Ray or join a cluster (``connect``).
* ``rap.farm.actors``: ``SimWorker``, the simulation actor (assemblies cached, physics in the worker).
* ``rap.farm.pool``: ``SimPool``, batching + bounded in-flight tasks + retries; shared by the
  labelling farm and the planner (``score`` in input order, ``stream`` in completion order).
* ``rap.farm.selection``: ``prepare`` and ``iter_jobs`` (inputs checked, operations selected; no Ray).
* ``rap.farm.rows``: ``label_rows``, one batch's dataset rows (no Ray; actors and bursts share it).
* ``rap.farm.driver``: ``rap-farm label`` (enumerate, resume, label, stream into Arrow shards).

Names are loaded lazily: ``from rap.farm import SimPool``.
"""

from __future__ import annotations

import importlib

__all__ = ["SimPool", "Scored", "Job", "FarmError", "Backend", "connect", "LabelConfig", "run_label",
           "prepare"]

_WHERE = {"SimPool": "pool", "Scored": "pool", "Job": "selection", "FarmError": "pool",
          "Backend": "rows", "connect": "runtime", "LabelConfig": "selection",
          "run_label": "driver", "prepare": "selection"}


def __getattr__(name: str):
    if name in _WHERE:
        return getattr(importlib.import_module(f"rap.farm.{_WHERE[name]}"), name)
    raise AttributeError(f"module 'rap.farm' has no attribute {name!r}")

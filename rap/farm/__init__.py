"""The labelling farm, the orchestration layer with ``rap.serve`` (the only packages that import
``ray``): it runs ``rap.labelling`` on Ray.

* ``rap.farm.runtime``: start an embedded Ray or join a cluster (``connect``).
* ``rap.farm.actors``: ``SimWorker``, the simulation actor (assemblies cached, physics in the worker).
* ``rap.farm.pool``: ``SimPool``, batching + bounded in-flight tasks + retries; shared by the
  labelling farm and the planner (``score`` in input order, ``stream`` in completion order).
* ``rap.farm.prefetch``: each assembly's operations selected by a Ray task of its own.
* ``rap.farm.driver``: ``rap-farm label`` (enumerate, resume, label, stream into Arrow shards).

Names are loaded lazily: ``from rap.farm import SimPool``.
"""

from __future__ import annotations

import importlib

__all__ = ["SimPool", "Scored", "Job", "FarmError", "Backend", "connect", "LabelConfig", "run_label",
           "prepare"]

_WHERE = {"SimPool": "rap.farm.pool", "Scored": "rap.farm.pool", "Job": "rap.labelling.selection",
          "FarmError": "rap.farm.pool", "Backend": "rap.labelling.rows", "connect": "rap.farm.runtime",
          "LabelConfig": "rap.labelling.selection", "run_label": "rap.farm.driver",
          "prepare": "rap.labelling.selection"}


def __getattr__(name: str):
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'rap.farm' has no attribute {name!r}")

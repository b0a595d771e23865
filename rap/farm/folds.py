"""Cross-validation folds as parallel Ray tasks.

Each fold (``rap.model.evaluation.cross_validation.run_fold`` over a plain-dict spec) is one task of ``num_cpus=1``
training with one torch thread, so a machine with k cores runs k folds at once. At most as many
tasks are in flight as the cluster has CPUs (``ray.wait``). Workers read the dataset and write the
fold checkpoints by path: on a multi-node cluster the dataset and models directories must be on
shared storage. Ray is reached as everywhere in the farm (``rap.farm.runtime.connect``): a running
Ray runtime is used as it is, else the cluster at ``RAY_ADDRESS`` is joined, else a local one is
started with ``num_cpus`` CPUs (all cores by default); one joined or started is shut down afterwards.
"""

from __future__ import annotations

from typing import Iterator

import ray

from rap.farm.runtime import connect

__all__ = ["ray_folds"]


def _fold(spec: dict) -> dict:
    import torch

    from rap.model.evaluation.cross_validation import run_fold

    torch.set_num_threads(1)
    return run_fold(spec)


def ray_folds(specs: list[dict], num_cpus: int | None = None) -> Iterator[dict]:
    """Run the folds as Ray tasks; yields each fold's result as it finishes."""
    with connect(num_cpus=num_cpus):  # joins RAY_ADDRESS or a running Ray, else starts one
        task = ray.remote(num_cpus=1, max_retries=0)(_fold)
        slots = max(1, int(ray.cluster_resources().get("CPU", 1)))
        pending = list(specs)
        running = []
        while pending or running:
            while pending and len(running) < slots:
                spec = dict(pending.pop(0))
                spec["train_config"] = {**spec["train_config"], "num_threads": 1}
                running.append(task.remote(spec))
            done, running = ray.wait(running, num_returns=1)
            yield ray.get(done[0])

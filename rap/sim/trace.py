"""Trajectories of a few simulated trials (for animated GIFs and inspection).

``trace`` runs exactly the simulation ``simulate`` runs for the same (assembly, operation, params,
rng state) -- all ``params.trials`` trials, the same noise -- and records the poses of the first
``k`` trials every ``every`` control steps, in assembly coordinates.
"""

from __future__ import annotations

import numpy as np

from rap.assembly import Assembly
from rap.operation import Operation
from rap.sim.params import DEFAULT_PARAMS, SimParams
from rap.sim.simulator import Trajectories, build_scene, run_trials

__all__ = ["trace", "Trajectories"]


def trace(assembly: Assembly, operation: Operation, params: SimParams | None = None,
          rng: np.random.Generator | None = None, k: int = 4, every: int = 4) -> Trajectories:
    """Poses of trials ``0..k-1`` (k <= params.trials) every ``every`` control steps.

    A trial's frames after it was decided repeat its last recorded pose (it left the space).
    """
    if rng is None:
        raise TypeError("trace needs rng=np.random.Generator")
    p = params if params is not None else DEFAULT_PARAMS
    k = max(1, min(k, p.trials))
    scene = build_scene(assembly, operation, p)
    info = run_trials(scene, p, rng, record=k, record_every=every)
    rec, decided = info.recording
    last = int(decided.max()) + 1
    rec = rec[:, :last]
    # forward-fill the frames after each trial left the space
    for t in range(k):
        good = ~np.isnan(rec[t, :, 0])
        idx = np.where(good, np.arange(last), 0)
        np.maximum.accumulate(idx, out=idx)
        rec[t] = rec[t, idx]
    cx, cy = scene.center
    pivot = (scene.pivot_world[0] / scene.scale + cx, scene.pivot_world[1] / scene.scale + cy)
    poses = np.empty_like(rec)
    poses[..., 0] = rec[..., 0] / scene.scale + cx - pivot[0]
    poses[..., 1] = rec[..., 1] / scene.scale + cy - pivot[1]
    poses[..., 2] = rec[..., 2]
    return Trajectories(pivot=pivot, poses=poses,
                        outcomes=tuple(int(o == 1) for o in info.outcome[:k]),
                        decided_frame=tuple(int(v) for v in decided),
                        frame_dt_s=p.dt_s * p.control_substeps * every,
                        start_offset=scene.start_offset)

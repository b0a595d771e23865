"""Whole-plan rollouts for the CLI (``execute --planar``, ``plan``): the cell's error model, the
assembly's unit in mm, and a runner on this machine's workers or on a Ray cluster (``--address``),
with a progress line. One home for what both commands need.

Ray is imported only when ``--address`` (or ``$RAY_ADDRESS``) asks for a cluster.
"""

from __future__ import annotations

import os
from contextlib import contextmanager

__all__ = ["cell_errors", "mm_per_unit", "rollout_runner"]


def cell_errors(cell, grasp_error_mm: float | None = None):
    """The cell's ``ErrorModel``; ``--grasp-error-mm`` (a shorthand) replaces its grasp error
    across the insertion."""
    from dataclasses import replace

    errors = cell.error_model()
    if grasp_error_mm is not None:
        errors = replace(errors, grasp_across_mm=float(grasp_error_mm))
    return errors


def mm_per_unit(cell, assembly) -> float:
    """Millimetres per unit of ``assembly`` in ``cell`` (``[assembly] unit_m`` for "unit")."""
    return cell.unit_metres(assembly.units) * 1000.0


@contextmanager
def rollout_runner(address: str | None, workers: int | None, on_chunk=None):
    """A ``RolloutRunner``: the farm's pool on the Ray cluster at ``address`` (or
    ``$RAY_ADDRESS``), else this machine's worker processes (``workers``, default every CPU)."""
    address = address or os.environ.get("RAY_ADDRESS") or None
    if address is None:
        from rap.plan.scoring.local_simulator import LocalSimulator

        sim = LocalSimulator(processes=workers or os.cpu_count() or 1)
        try:
            yield sim
        finally:
            sim.close()
        return
    from rap.farm.pool import SimPool
    from rap.farm.rollouts import PoolRollouts
    from rap.farm.runtime import connect

    with connect(address), SimPool(workers) as pool:
        yield PoolRollouts(pool, on_chunk=on_chunk)


def execution_options(execution, assembly, method: str, options: dict):
    """``(ExecutionOptions or None, the planner's options)`` for ``rap-farm plan``: ``execution``
    is ``(cell file, candidates, perturbed)`` or None (``--no-rollouts``); the search gets
    ``alternatives`` = candidates, and ``perturbed`` offers the choice the best plan on
    perturbed-start scores (``ExecutionOptions.perturbed``)."""
    if execution is None:
        return None, options
    from rap.plan.execution import ExecutionOptions
    from rap.robot.cell import load_cell

    cell_file, candidates, perturbed = execution
    cell = load_cell(cell_file)
    if method == "search" and candidates and options.get("alternatives") is None:
        options = {**options, "alternatives": int(candidates)}
    return ExecutionOptions(errors=cell_errors(cell), mm_per_unit=mm_per_unit(cell, assembly),
                            perturbed=bool(perturbed)), options

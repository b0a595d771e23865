"""The labelling driver behind ``rap-farm label``: select, skip what is done, label, stream to disk.

``run_label(LabelConfig(...))``:

1. takes the dataset's one-writer lock (``rap.dataset.lock_dataset``: a second run on the same
   ``--out`` is refused at once, exit 3, naming the holder's pid and host), checks every input
   before any work (assembly files and geometry, options, the output directory and, when it
   already holds a dataset, that it was written with the same root seed, simulator parameters and
   assembly geometry, and that its shards read) and decides per assembly which operations it takes
   (``rap.enumerate.select_operations``: every operation, refused at once past the budget when
   uncapped, or a seeded sample of ``max_ops_per_assembly`` drawn lazily); raises ``InputError``
   with one line otherwise; nothing existing is modified when a check fails;
2. starts or joins Ray (``rap.farm.runtime.connect``) and streams the selections into a
   ``SimPool`` with bounded in-flight batches, skipping operations whose key is already in the
   dataset (resume). With several assemblies the selecting runs in parallel Ray tasks, one per
   assembly (``rap.farm.prefetch``: the driver's CPU per operation falls about fivefold,
   benchmarks/driver_ceiling.py), else in the driver's thread; nothing is selected far ahead of
   what is in flight, so the driver's memory is bounded by the work in flight and the keys of the
   assemblies being selected, not by the size of any operation space;
3. commits rows atomically (``rap.dataset.write_shard``): the first shard within
   ``first_flush_seconds`` of the first result, then every ``flush_rows`` rows or
   ``flush_seconds`` seconds;
4. isolates failures: an assembly whose enumeration or simulation fails is named in
   ``LabelSummary.failed`` and skipped from then on; what was committed (for it and for every other
   assembly) stays, and the others are labelled to the end;
5. releases the lock after the last commit (or on any error; a killed run's lock goes with its
   process). A write that fails (disk full) raises ``rap.errors.StorageError`` (exit 3) naming the
   path; no temporary file is left and every committed shard stays.

The summary (``format_summary``) says which assemblies' samples stopped short of
``max_ops_per_assembly`` and why (``LabelSummary.short``), and how many rows of the dataset repeat
a key (written by two runs before the lock existed; readers keep each key's first row).

An interruption (Ctrl-C, SIGTERM from ``ray job stop``) commits the rows already received and
re-raises; SIGKILL loses at most the rows of the last ``flush_rows``/``flush_seconds``. A rerun of the
same command completes the dataset to exactly the rows of an uninterrupted run.
"""

from __future__ import annotations

import json
import signal
import threading
import time
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from rap.dataset import (SCHEMA_VERSION, DatasetMeta, clean_partial_files, write_geometry, write_meta,
                         write_shard)
from rap.errors import InputError, sigterm_as_interrupt

from rap.farm.pool import IDLE_TIMEOUT_S, Job, SimPool
from rap.labelling.rows import dataset_table
from rap.farm.runtime import connect, node_churn, nodes_now
from rap.farm.prefetch import parallel_jobs
from rap.labelling.selection import (HIST_BINS, LabelConfig, LabelPlan, LabelSummary, iter_jobs, prepare,
                               selects_in_tasks)

__all__ = ["PRESETS", "LabelConfig", "LabelPlan", "LabelSummary", "prepare", "run_label",
           "format_summary"]

# name -> (trials, max operations per assembly); see datasets/README.md for the sizes and times.
PRESETS: dict[str, tuple[int, int | None]] = {
    "tiny": (20, 12),
    "default": (100, 2000),
    "full": (100, None),
}

# -- running ------------------------------------------------------------------------------------
class _Uninterruptible:
    """Defers Ctrl-C / SIGTERM until a commit (shard write + bookkeeping) is complete, so an
    interruption can never commit rows and then lose track of them (which would write them twice)."""

    def __enter__(self):
        self._got: list[int] = []
        self._old = None
        if threading.current_thread() is threading.main_thread():
            self._old = {s: signal.signal(s, lambda signum, frame: self._got.append(signum))
                         for s in (signal.SIGINT, signal.SIGTERM)}
        return self

    def __exit__(self, exc_type, exc, tb):
        if self._old is not None:
            for s, h in self._old.items():
                signal.signal(s, h)
        if self._got and exc_type is None:
            raise KeyboardInterrupt
        return False


def _progress(enabled: bool, total: int):
    from rich.console import Console
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, ProgressColumn,
                               TextColumn, TimeElapsedColumn, TimeRemainingColumn)
    from rich.text import Text

    class Rate(ProgressColumn):
        def render(self, task):
            speed = task.finished_speed or task.speed
            return Text(f"{speed:6.1f} ops/s" if speed else "   -- ops/s", style="progress.data.speed")

    return Progress(TextColumn("[bold]label"), BarColumn(), MofNCompleteColumn(), Rate(),
                    TextColumn("eta"), TimeRemainingColumn(), TimeElapsedColumn(),
                    console=Console(stderr=True), disable=not enabled, transient=False,
                    speed_estimate_period=60.0)


def _peak_rss_mib() -> float:
    """Peak resident memory of this process (the driver; Ray's workers are other processes)."""
    import resource

    kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return kib / 1024.0


def run_label(cfg: LabelConfig, plan: LabelPlan | None = None,
              on_batch: Callable[[LabelSummary], None] | None = None) -> LabelSummary:
    """Label everything ``cfg`` asks for that is not in the dataset yet; see the module docstring."""
    plan = plan or prepare(cfg)
    if plan.lock is not None and not plan.lock.held:
        raise InputError(f"--out {cfg.out}: this plan's lock on the dataset was released (the plan "
                         f"was run or closed): prepare the run again")
    try:
        return _run_label(cfg, plan, on_batch)
    finally:
        plan.release()  # after the last commit


def _run_label(cfg: LabelConfig, plan: LabelPlan,
               on_batch: Callable[[LabelSummary], None] | None) -> LabelSummary:
    t_start = plan.started
    out = Path(cfg.out)
    summary = LabelSummary(out=str(out), total=plan.total,
                           dataset_duplicates=plan.duplicates.rows if plan.duplicates else 0)

    def commit_meta() -> None:
        if plan.new_dataset:
            write_meta(out, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=int(cfg.seed),
                                        params=json.loads(json.dumps(plan.params.to_dict())),
                                        command=cfg.command))
        write_geometry(out, plan.assemblies)
        clean_partial_files(out)

    if plan.total == 0:
        commit_meta()
        return summary

    pending: set[str] = set()  # keys submitted and not yet written (in flight)
    buffer: list[pa.Table] = []  # received batches (wire tables), not yet committed
    buffered = 0
    last_flush = time.monotonic()
    first_result: float | None = None
    t0 = time.perf_counter()

    def flush() -> None:
        nonlocal last_flush, buffered
        if buffer:
            with _Uninterruptible():
                table = dataset_table(pa.concat_tables(buffer))
                summary.shards += len(write_shard(out, table))
                tally_rows(summary, table)
                buffer.clear()
                buffered = 0
            if summary.first_shard_s is None:
                summary.first_shard_s = time.perf_counter() - t_start
        last_flush = time.monotonic()

    def tracked(jobs: Iterator[Job]) -> Iterator[Job]:
        for j in jobs:
            pending.add(j.key)
            yield j

    # ``ray job stop`` and schedulers send SIGTERM: as Ctrl-C (commit, then stop); the CLI's
    # handler, when there is one, is kept
    with sigterm_as_interrupt(keep=True), connect(cfg.address, num_cpus=cfg.num_cpus) as rt:
        commit_meta()  # only once Ray is up: a failed connection leaves nothing behind
        # elastic: up to --workers actors (default: every CPU, growing as CPUs join), labelling as
        # soon as one runs; idle ones are released so an autoscaler can remove their nodes
        pool = SimPool(cfg.workers, backend=cfg.backend, batch_size=cfg.batch_size,
                       idle_timeout_s=IDLE_TIMEOUT_S, stall_timeout_s=cfg.start_timeout_s,
                       progress_timeout_s=cfg.progress_timeout_s)
        summary.workers = pool.size
        progress = _progress(cfg.progress, plan.total)
        nodes_before = nodes_now()
        gens: list = []  # the generators of jobs and results, closed while Ray is up
        try:
            pool.ready(cfg.start_timeout_s, at_least=1)
            summary.startup_s = time.perf_counter() - t0
            t0 = time.perf_counter()  # the rate counts labelling time only
            with progress:
                bar = progress.add_task("label", total=plan.total)
                skipped = lambda k: progress.advance(bar, k)  # noqa: E731
                resize = lambda: progress.update(bar, total=summary.total)  # noqa: E731
                if selects_in_tasks(cfg, len(plan.assemblies)):
                    gens.append(parallel_jobs(plan, summary, skipped,
                                              tasks=cfg.selection_tasks or rt.cpus,
                                              recounted=resize))
                else:
                    gens.append(iter_jobs(plan, summary, skipped, resize))
                gens.append(tracked(gens[-1]))
                gens.append(pool.stream(gens[-1], plan.params, images=True, errors="collect"))
                for res in gens[-1]:
                    if res.error is not None:
                        summary.failed.setdefault(res.assembly, res.error)
                    table = fresh_rows(res.table, pending)
                    summary.duplicates += res.num_rows - table.num_rows
                    if table.num_rows:
                        buffer.append(table)
                        buffered += table.num_rows
                    progress.advance(bar, table.num_rows)
                    now = time.monotonic()
                    if first_result is None and res.num_rows:
                        first_result = now
                    if (buffered >= cfg.flush_rows or now - last_flush >= cfg.flush_seconds
                            or (summary.shards == 0 and first_result is not None
                                and now - first_result >= cfg.first_flush_seconds)):
                        flush()
                    if on_batch is not None:
                        on_batch(summary)
        except KeyboardInterrupt:
            summary.interrupted = True
            raise
        finally:
            try:
                flush()  # commit what has arrived, also when interrupted
            finally:
                for g in reversed(gens):  # now, not when collected after Ray has gone
                    _close(g)
                summary.seconds = time.perf_counter() - t0
                summary.workers = max(1, pool.stats["peak_workers"])
                summary.resubmitted = pool.stats["resubmitted"]
                summary.lost = pool.stats["lost"]
                summary.redone_ops = pool.stats["redone_ops"]
                summary.nodes_joined, summary.nodes_left = node_churn(nodes_before, nodes_now())
                summary.sim_s = pool.stats["sim_s"]
                summary.task_s = pool.stats["task_s"]
                summary.peak_rss_mib = _peak_rss_mib()
                pool.shutdown()
    return summary


def _close(gen) -> None:
    try:
        gen.close()
    except Exception:  # a generator's cleanup never hides the run's own outcome
        pass


def fresh_rows(table: pa.Table, pending: set[str]) -> pa.Table:
    """The rows of ``table`` whose key is in ``pending`` (in flight, not yet received), taking each
    key out of it: a batch that arrives twice (resubmitted after a lost node) adds nothing.
    O(rows)."""
    keep = []
    for k in table.column("key").to_pylist():
        keep.append(k in pending)
        pending.discard(k)
    return table if all(keep) else table.filter(pa.array(keep, pa.bool_()))


def tally_rows(summary: LabelSummary, table: pa.Table) -> None:
    """Add committed rows to the summary: rows per node and per assembly, the score histogram."""
    summary.labelled += table.num_rows
    for column, counts in (("node", summary.nodes), ("assembly", summary.per_assembly)):
        for vc in pc.value_counts(table.column(column)).to_pylist():
            counts[vc["values"]] = counts.get(vc["values"], 0) + vc["counts"]
    bins = np.clip((table.column("score").to_numpy() * HIST_BINS).astype(np.int64), 0, HIST_BINS - 1)
    for b, n in enumerate(np.bincount(bins, minlength=HIST_BINS)):
        summary.hist[b] += int(n)


def format_summary(s: LabelSummary, no_limit: str = "no limit") -> str:
    """A plain-text summary: operations, rate, time, nodes, score histogram (``no_limit``: how a
    short sample's line says to label every operation, ``Shortfall.describe``)."""
    lines = [
        f"dataset      {s.out}",
        f"operations   {s.total} selected, {s.existing} already present, {s.labelled} labelled now"
        + (f", {s.duplicates} duplicate results dropped" if s.duplicates else ""),
        f"time         {s.seconds:.1f} s labelling (+{s.startup_s:.1f} s starting Ray), "
        f"{s.rate:.2f} ops/s with {s.workers} workers"
        + (f" ({s.sim_s / s.task_s:.0%} of worker time in the simulator)" if s.task_s > 0 else ""),
        f"shards       {s.shards}",
    ]
    if s.resubmitted or s.nodes_joined or s.nodes_left:
        lines.append(f"churn        {s.nodes_joined} nodes joined, {s.nodes_left} left; "
                     f"{s.lost} batches lost with their workers, {s.resubmitted} batches "
                     f"resubmitted ({s.redone_ops} operations redone)")
    if s.per_assembly:
        lines.append("assemblies   " + ", ".join(f"{k} {v}" for k, v in sorted(s.per_assembly.items())))
    if len(s.nodes) == 1:
        lines.append("nodes        " + " ".join(f"{k} {v}" for k, v in s.nodes.items()))
    elif s.nodes:  # one line each: a node is hostname/<the whole Ray node id>
        lines.append(f"nodes        {len(s.nodes)}, rows per node:")
        lines += [f"  {v:8d}  {k}" for k, v in sorted(s.nodes.items())]
    if s.first_shard_s is not None:
        lines.append(f"first shard  committed {s.first_shard_s:.1f} s after the start")
    if s.peak_rss_mib:
        lines.append(f"driver       peak RSS {s.peak_rss_mib:.0f} MiB")
    for name, short in sorted(s.short.items()):
        lines.append(f"short        {name}: {short.describe(no_limit)}")
    if s.dataset_duplicates:
        lines.append(f"duplicates   {s.dataset_duplicates} rows of the dataset repeat a key stored "
                     f"before them (readers use each key's first row); this run added none")
    for name, why in sorted(s.failed.items()):
        lines.append(f"FAILED       {name}: {why} (its committed rows and every other assembly's are kept)")
    if s.labelled:
        lines.append("score histogram (this run)")
        peak = max(s.hist) or 1
        for i, c in enumerate(s.hist):
            lo, hi = i / HIST_BINS, (i + 1) / HIST_BINS
            bar = "#" * int(round(40 * c / peak))
            lines.append(f"  [{lo:.1f}, {hi:.1f}{']' if i == HIST_BINS - 1 else ')'} {c:7d} {bar}")
    return "\n".join(lines)

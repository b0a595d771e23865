"""The labelling driver behind ``rap-farm label``: select, skip what is done, label, stream to disk.

``run_label(LabelConfig(...))``:

1. checks every input before any work (assembly files and geometry, options, the output directory
   and, when it already holds a dataset, that it was written with the same root seed, simulator
   parameters and assembly geometry) and decides per assembly which operations it takes
   (``rap.enumerate.select_operations``: every operation, refused at once past the budget when
   uncapped, or a seeded sample of ``max_ops_per_assembly`` drawn lazily); raises ``InputError``
   with one line otherwise; nothing existing is modified when a check fails;
2. starts or joins Ray (``rap.farm.runtime.connect``) and streams the selections, assembly after
   assembly, into a ``SimPool`` with bounded in-flight batches, skipping operations whose key is
   already in the dataset (resume); nothing is enumerated ahead of what is in flight, so the
   driver's memory is bounded by the work in flight and the keys of one assembly, not by the size
   of any operation space;
3. commits rows atomically (``rap.dataset.write_shard``): the first shard within
   ``first_flush_seconds`` of the first result, then every ``flush_rows`` rows or
   ``flush_seconds`` seconds;
4. isolates failures: an assembly whose enumeration or simulation fails is named in
   ``LabelSummary.failed`` and skipped from then on; what was committed (for it and for every other
   assembly) stays, and the others are labelled to the end.

An interruption (Ctrl-C, SIGTERM from ``ray job stop``) commits the rows already received and
re-raises; SIGKILL loses at most the rows of the last ``flush_rows``/``flush_seconds``. A rerun of the
same command completes the dataset to exactly the rows of an uninterrupted run.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from rap.assembly import Assembly
from rap.io import load_assembly
from rap.dataset import (METADATA_FILE, SCHEMA_VERSION, DatasetMeta, clean_partial_files, existing_keys,
                         open_dataset, read_meta, rows_to_table, write_meta, write_shard)
from rap.enumerate import MODES, Selection, label_key, label_seed, select_operations
from rap.errors import InputError, RapError
from rap.operation import Operation

from rap.farm.actors import Backend, resolve
from rap.farm.pool import Job, SimPool
from rap.farm.runtime import connect

__all__ = ["PRESETS", "LabelConfig", "LabelPlan", "LabelSummary", "prepare", "run_label",
           "format_summary"]

# name -> (trials, max operations per assembly); see datasets/README.md for the sizes and times.
PRESETS: dict[str, tuple[int, int | None]] = {
    "tiny": (20, 12),
    "default": (100, 2000),
    "full": (100, None),
}

HIST_BINS = 10


@dataclass(frozen=True)
class LabelConfig:
    """Everything ``rap-farm label`` takes. ``backend`` names the simulator/renderer/params."""

    assemblies: tuple[str, ...]
    out: str
    address: str | None = None
    workers: int | None = None
    trials: int = 100
    seed: int = 0
    max_ops_per_assembly: int | None = None
    directions_per_range: int = 1
    mode: str = "all"
    flush_rows: int = 512
    flush_seconds: float = 30.0
    first_flush_seconds: float = 2.0
    batch_size: int | None = None
    num_cpus: int | None = None  # embedded Ray only: CPUs to start it with (default: all)
    backend: Backend = Backend()
    params_factory: str = "rap.sim.params:SimParams"
    progress: bool = True
    command: str = "rap-farm label"


@dataclass
class LabelPlan:
    """What ``prepare`` found: the checked inputs and, per assembly, the lazy selection."""

    config: LabelConfig
    assemblies: list[Assembly]
    params: Any
    selections: dict[str, Selection]  # assembly name -> what the run takes from it
    existing_keys: set[str]  # keys already in the dataset (resume)
    new_dataset: bool
    started: float = field(default_factory=time.perf_counter)  # perf_counter at prepare()

    @property
    def total(self) -> int:
        return sum(s.total for s in self.selections.values())

    @property
    def existing_rows(self) -> int:
        return len(self.existing_keys)


@dataclass
class LabelSummary:
    out: str
    total: int = 0  # operations selected
    existing: int = 0  # already in the dataset before this run
    labelled: int = 0  # rows committed by this run
    duplicates: int = 0  # results dropped because their key was already written
    shards: int = 0
    seconds: float = 0.0  # labelling (after the actors are up)
    workers: int = 0
    nodes: dict[str, int] = field(default_factory=dict)
    per_assembly: dict[str, int] = field(default_factory=dict)
    hist: list[int] = field(default_factory=lambda: [0] * HIST_BINS)
    resubmitted: int = 0
    failed: dict[str, str] = field(default_factory=dict)  # assembly name -> what went wrong
    first_shard_s: float | None = None  # from the start of prepare() to the first commit
    peak_rss_mib: float = 0.0  # the driver process's peak resident memory
    sim_s: float = 0.0
    task_s: float = 0.0
    startup_s: float = 0.0  # starting/joining Ray and the actors
    interrupted: bool = False

    @property
    def rate(self) -> float:
        return self.labelled / self.seconds if self.seconds > 0 else 0.0


# -- checks -------------------------------------------------------------------------------------
def _check_out_dir(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a directory")
    if out.is_dir() and not (out / METADATA_FILE).exists():
        # entries named _* or .* are not data (readers skip them too): e.g. a corpus's _assemblies
        if any(p for p in out.iterdir() if not p.name.startswith(("_", "."))):
            raise InputError(f"--out {out}: directory is not empty and holds no rap-farm dataset "
                             f"({METADATA_FILE} missing); choose a new or empty directory")
    # Writable? Probe in the nearest existing ancestor without creating anything in the dataset.
    probe_dir = out
    while not probe_dir.exists():
        if probe_dir.parent == probe_dir:
            break
        probe_dir = probe_dir.parent
    if not probe_dir.is_dir():
        raise InputError(f"--out {out}: {probe_dir} is not a directory")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".rapfarm-probe-", dir=probe_dir)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        raise InputError(f"--out {out}: not writable ({exc.strerror or exc})") from None


def _diff(a: dict, b: dict) -> str:
    keys = sorted(set(a) | set(b))
    bad = [k for k in keys if a.get(k) != b.get(k)]
    return ", ".join(f"{k} {a.get(k)!r} != {b.get(k)!r}" for k in bad[:3]) + (" ..." if len(bad) > 3 else "")


def _check_meta(out: Path, root_seed: int, params: Any) -> bool:
    """True when ``out`` holds no dataset yet; raises when it holds an incompatible one."""
    meta = read_meta(out)
    if meta is None:
        return True
    if meta.schema_version != SCHEMA_VERSION:
        raise InputError(f"--out {out}: dataset schema version {meta.schema_version}, this code "
                         f"writes {SCHEMA_VERSION}; choose another --out")
    if int(meta.root_seed) != int(root_seed):
        raise InputError(f"--out {out}: dataset was labelled with --seed {meta.root_seed}, not "
                         f"{root_seed}; rerun with --seed {meta.root_seed} or choose another --out")
    want = json.loads(json.dumps(params.to_dict()))
    if meta.params != want:
        raise InputError(f"--out {out}: dataset was labelled with other simulator parameters "
                         f"({_diff(meta.params, want)}); choose another --out")
    return False


def _check_geometry(out: Path, assemblies: Sequence[Assembly]) -> None:
    if not any(out.glob("*/part-*.parquet")):
        return
    import pyarrow.compute as pc

    t = open_dataset(out).to_table(columns=["assembly", "geometry_hash"])
    pairs = pc.unique(pc.binary_join_element_wise(t["assembly"], t["geometry_hash"], "\0")).to_pylist()
    stored: dict[str, set[str]] = {}
    for s in pairs:
        name, gh = s.split("\0")
        stored.setdefault(name, set()).add(gh)
    for a in assemblies:
        other = stored.get(a.name, set()) - {a.geometry_hash}
        if other:
            raise InputError(f"--out {out}: assembly {a.name!r} in the dataset has other geometry "
                             f"({sorted(other)[0]} != {a.geometry_hash}); was {a.source} changed? "
                             f"choose another --out")


def prepare(cfg: LabelConfig, status: Callable[[str], None] = lambda s: None) -> LabelPlan:
    """Check every input and decide what each assembly contributes. Raises ``InputError``;
    writes nothing. Enumerates nothing beyond a bounded count per assembly."""
    started = time.perf_counter()
    if not cfg.assemblies:
        raise InputError("no assembly given")
    if cfg.trials < 1:
        raise InputError(f"--trials must be >= 1, not {cfg.trials}")
    if cfg.workers is not None and cfg.workers < 1:
        raise InputError(f"--workers must be >= 1, not {cfg.workers}")
    if cfg.max_ops_per_assembly is not None and cfg.max_ops_per_assembly < 1:
        raise InputError(f"--max-ops-per-assembly must be >= 1, not {cfg.max_ops_per_assembly}")
    if cfg.directions_per_range < 1:
        raise InputError(f"--directions-per-range must be >= 1, not {cfg.directions_per_range}")
    if cfg.mode not in MODES:
        raise InputError(f"--mode must be one of {', '.join(MODES)}, not {cfg.mode!r}")
    if not (0 <= int(cfg.seed) < 2 ** 63):
        raise InputError(f"--seed must be in [0, 2**63), not {cfg.seed}")
    if cfg.flush_rows < 1 or cfg.flush_seconds <= 0 or cfg.first_flush_seconds <= 0:
        raise InputError("flush_rows must be >= 1 and flush_seconds, first_flush_seconds > 0")

    assemblies: list[Assembly] = []
    names: dict[str, str] = {}
    for path in cfg.assemblies:
        a = load_assembly(path)  # AssemblyError (an InputError): missing file, invalid geometry
        if a.name in names:
            if a.geometry_hash == names[a.name]:
                continue  # the same assembly twice
            raise InputError(f"{path}: assembly name {a.name!r} is used by another assembly "
                             f"with different geometry in this command")
        names[a.name] = a.geometry_hash
        assemblies.append(a)

    out = Path(cfg.out)
    _check_out_dir(out)
    params_cls = resolve(cfg.params_factory)
    try:
        params = params_cls(trials=int(cfg.trials))
    except (TypeError, ValueError) as exc:
        raise InputError(f"invalid simulator parameters: {exc}") from None
    new = _check_meta(out, cfg.seed, params)
    _check_geometry(out, assemblies)

    selections: dict[str, Selection] = {}
    for a in assemblies:
        status(f"counting {a.name}")
        # TooManyOperations (an InputError): uncapped and beyond the budget, refused at once
        selections[a.name] = select_operations(a, cfg.max_ops_per_assembly, cfg.seed, cfg.mode,
                                               cfg.directions_per_range)
    return LabelPlan(config=cfg, assemblies=assemblies, params=params, selections=selections,
                     existing_keys=existing_keys(out), new_dataset=new, started=started)


# -- running ------------------------------------------------------------------------------------
@contextlib.contextmanager
def _sigterm_as_interrupt() -> Iterator[None]:
    """``ray job stop`` and schedulers send SIGTERM: treat it like Ctrl-C (commit, then stop)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


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


def _jobs(plan: LabelPlan, summary: LabelSummary, skipped: Callable[[int], None]) -> Iterator[Job]:
    """The jobs of every selection, assembly after assembly, lazily; skips what is already in the
    dataset and every assembly in ``summary.failed``. A failing enumeration fails its assembly only."""
    fp = plan.params.fingerprint()
    seed = plan.config.seed
    existing = plan.existing_keys
    for a in plan.assemblies:
        gh = a.geometry_hash
        seen: set[str] = set()  # this assembly's keys (its selection is distinct by construction)
        try:
            for op in plan.selections[a.name]:
                if a.name in summary.failed:
                    break
                key = label_key(op, gh, fp, seed)
                if key in seen:
                    continue
                seen.add(key)
                if key in existing:
                    summary.existing += 1
                    skipped(1)
                    continue
                yield Job(a, op, key, label_seed(op, gh, fp, seed))
        except (RapError, ValueError, ArithmeticError, RecursionError, MemoryError) as exc:
            summary.failed.setdefault(a.name, f"selecting operations failed: {_one_line(exc)}")


def _peak_rss_mib() -> float:
    """Peak resident memory of this process (the driver; Ray's workers are other processes)."""
    import resource

    kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return kib / 1024.0


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[-1] if text else type(exc).__name__


def run_label(cfg: LabelConfig, plan: LabelPlan | None = None,
              on_batch: Callable[[LabelSummary], None] | None = None) -> LabelSummary:
    """Label everything ``cfg`` asks for that is not in the dataset yet; see the module docstring."""
    plan = plan or prepare(cfg)
    t_start = plan.started
    out = Path(cfg.out)
    summary = LabelSummary(out=str(out), total=plan.total)

    def commit_meta() -> None:
        if plan.new_dataset:
            write_meta(out, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=int(cfg.seed),
                                        params=json.loads(json.dumps(plan.params.to_dict())),
                                        command=cfg.command))
        clean_partial_files(out)

    if plan.total == 0:
        commit_meta()
        return summary

    pending: set[str] = set()  # keys submitted and not yet written (in flight)
    buffer: list[dict] = []
    last_flush = time.monotonic()
    first_result: float | None = None
    t0 = time.perf_counter()

    def flush() -> None:
        nonlocal last_flush
        if buffer:
            with _Uninterruptible():
                summary.shards += len(write_shard(out, rows_to_table(buffer)))
                summary.labelled += len(buffer)
                for r in buffer:
                    summary.nodes[r["node"]] = summary.nodes.get(r["node"], 0) + 1
                    summary.per_assembly[r["assembly"]] = summary.per_assembly.get(r["assembly"], 0) + 1
                    b = min(HIST_BINS - 1, max(0, int(r["score"] * HIST_BINS)))
                    summary.hist[b] += 1
                buffer.clear()
            if summary.first_shard_s is None:
                summary.first_shard_s = time.perf_counter() - t_start
        last_flush = time.monotonic()

    def tracked(jobs: Iterator[Job]) -> Iterator[Job]:
        for j in jobs:
            pending.add(j.key)
            yield j

    with _sigterm_as_interrupt(), connect(cfg.address, num_cpus=cfg.num_cpus) as rt:
        commit_meta()  # only once Ray is up: a failed connection leaves nothing behind
        pool = SimPool(cfg.workers or rt.cpus, backend=cfg.backend, batch_size=cfg.batch_size)
        summary.workers = pool.size
        progress = _progress(cfg.progress, plan.total)
        try:
            pool.ready()
            summary.startup_s = time.perf_counter() - t0
            t0 = time.perf_counter()  # the rate counts labelling time only
            with progress:
                bar = progress.add_task("label", total=plan.total)
                jobs = tracked(_jobs(plan, summary, lambda k: progress.advance(bar, k)))
                for res in pool.stream(jobs, plan.params, images=True, errors="collect"):
                    if res.error is not None:
                        summary.failed.setdefault(res.assembly, res.error)
                    fresh = 0
                    for row in res.rows:
                        if row["key"] in pending:
                            pending.discard(row["key"])
                            buffer.append(row)
                            fresh += 1
                        else:
                            summary.duplicates += 1
                    progress.advance(bar, fresh)
                    now = time.monotonic()
                    if first_result is None and res.rows:
                        first_result = now
                    if (len(buffer) >= cfg.flush_rows or now - last_flush >= cfg.flush_seconds
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
                summary.seconds = time.perf_counter() - t0
                summary.resubmitted = pool.stats["resubmitted"]
                summary.sim_s = pool.stats["sim_s"]
                summary.task_s = pool.stats["task_s"]
                summary.peak_rss_mib = _peak_rss_mib()
                pool.shutdown()
    return summary


def format_summary(s: LabelSummary) -> str:
    """A plain-text summary: operations, rate, time, nodes, score histogram."""
    lines = [
        f"dataset      {s.out}",
        f"operations   {s.total} selected, {s.existing} already present, {s.labelled} labelled now"
        + (f", {s.duplicates} duplicate results dropped" if s.duplicates else "")
        + (f", {s.resubmitted} batches resubmitted" if s.resubmitted else ""),
        f"time         {s.seconds:.1f} s labelling (+{s.startup_s:.1f} s starting Ray), "
        f"{s.rate:.2f} ops/s with {s.workers} workers"
        + (f" ({s.sim_s / s.task_s:.0%} of worker time in the simulator)" if s.task_s > 0 else ""),
        f"shards       {s.shards}",
    ]
    if s.per_assembly:
        lines.append("assemblies   " + ", ".join(f"{k} {v}" for k, v in sorted(s.per_assembly.items())))
    if s.nodes:
        lines.append("nodes        " + ", ".join(f"{k} {v}" for k, v in sorted(s.nodes.items())))
    if s.first_shard_s is not None:
        lines.append(f"first shard  committed {s.first_shard_s:.1f} s after the start")
    if s.peak_rss_mib:
        lines.append(f"driver       peak RSS {s.peak_rss_mib:.0f} MiB")
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

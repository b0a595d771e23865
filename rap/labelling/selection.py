"""What a labelling run takes, decided without Ray: inputs checked, operations selected, jobs.

``prepare(LabelConfig(...))`` checks every input before any work (assembly files and geometry,
options, the output directory and, when it already holds a dataset, that it was written with the
same root seed, simulator parameters and assembly geometry) and decides per assembly which
operations it takes (``rap.enumerate.select_operations``); ``iter_jobs`` then yields, lazily and
assembly after assembly, the ``Job`` of every selected operation not yet in the dataset, and
records in ``LabelSummary.short`` each assembly whose selection ended before its total, with why.
The Ray driver (``rap.farm.driver``) and the Ray-free burst labeller (``scripts/label_burst.py``)
share it, so both label exactly the same operations with the same keys and seeds.

One writer per dataset: ``prepare`` takes the dataset's lock (``rap.dataset.lock_dataset``) before
it reads anything that decides what to label, and the plan holds it until ``LabelPlan.release()``
(``run_label`` releases it after its last commit; so does the end of the process). A second
``prepare`` on the same ``--out`` meanwhile raises ``DatasetBusyError`` (exit 3) naming the
holder's pid and host, and writes nothing.
"""

from __future__ import annotations

import json
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from rap.assembly import Assembly
from rap.dataset import (METADATA_FILE, SCHEMA_VERSION, DatasetLock, Duplicates, duplicate_keys,
                         existing_keys, lock_dataset, read_meta, read_table)
from rap.enumerate import (MODES, Selection, Shortfall, defer_selection, label_key, label_seed,
                           select_operations)
from rap.errors import InputError, RapError
from rap.io import load_assembly
from rap.operation import Operation

from rap.labelling.rows import Backend, resolve

__all__ = ["Job", "LabelConfig", "LabelPlan", "LabelSummary", "Outcome", "prepare", "select_jobs",
           "record", "iter_jobs", "HIST_BINS"]

HIST_BINS = 10


@dataclass(frozen=True)
class Job:
    """One operation to label: its assembly, content key (dataset identity) and simulator seed.
    ``operation`` may be packed (``rap.farm.actors.pack``) when it only passes through."""

    assembly: Assembly
    operation: Operation | bytes
    key: str
    seed: int


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
    start_timeout_s: float = 120.0  # simulation workers must start within this (FarmError)
    progress_timeout_s: float = 600.0  # a batch lost with its worker is given up once no batch
    # has completed for this long (rap.farm.faults.PROGRESS_TIMEOUT_S)
    backend: Backend = Backend()
    selection_tasks: int | None = None  # assemblies selected at once in Ray tasks (None: one per
    # CPU of the cluster; 0: in the driver's thread, assembly after assembly): rap.farm.prefetch
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
    lock: DatasetLock | None = None  # the dataset's one-writer lock, held until release()
    duplicates: Duplicates | None = None  # keys the dataset already held more than once

    def release(self) -> None:
        """Release the dataset's lock (idempotent): no more rows will be written by this plan."""
        if self.lock is not None:
            self.lock.release()

    def __enter__(self) -> "LabelPlan":
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    @property
    def total(self) -> int:
        """Operations the selections take (an upper bound while one is not counted yet)."""
        return sum(s.total for s in self.selections.values())

    @property
    def total_text(self) -> str:
        """``total`` as a user reads it: "N", or "up to N" while a selection is not counted."""
        capped = any(s.how == "capped" for s in self.selections.values())
        return f"up to {self.total}" if capped else str(self.total)

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
    resubmitted: int = 0  # batches sent again (lost with their workers, or failed and retried)
    lost: int = 0  # batches lost with their workers (actor, node)
    redone_ops: int = 0  # operations sent again (work redone)
    nodes_joined: int = 0  # nodes of the cluster that joined while the run ran
    nodes_left: int = 0  # nodes that left (died, removed) while the run ran
    failed: dict[str, str] = field(default_factory=dict)  # assembly name -> what went wrong
    first_shard_s: float | None = None  # from the start of prepare() to the first commit
    peak_rss_mib: float = 0.0  # the driver process's peak resident memory
    sim_s: float = 0.0
    task_s: float = 0.0
    startup_s: float = 0.0  # starting/joining Ray and the actors
    interrupted: bool = False
    dataset_duplicates: int = 0  # rows the dataset held before this run whose key was stored before
    short: dict[str, Shortfall] = field(default_factory=dict)  # selections that ended early

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

    t = read_table(out, columns=["assembly", "geometry_hash"])
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
    """Check every input, take the dataset's lock and decide what each assembly contributes.
    Raises ``InputError`` (``CorruptShardError`` for a shard that does not read),
    ``DatasetBusyError`` when another run holds the lock; writes nothing but the lock file (and
    ``--out`` when missing: both go with ``LabelPlan.release()``). Enumerates nothing beyond a
    bounded count per assembly."""
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
        raise InputError(f"--space must be one of {', '.join(MODES)}, not {cfg.mode!r}")
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
    lock = lock_dataset(out, cfg.command)  # before anything read decides what to label
    try:
        new = _check_meta(out, cfg.seed, params)
        _check_geometry(out, assemblies)

        selections: dict[str, Selection] = {}
        for a in assemblies:
            if cfg.max_ops_per_assembly is not None and selects_in_tasks(cfg, len(assemblies)):
                # counted by the assembly's selection task (rap.farm.prefetch), not here
                selections[a.name] = defer_selection(a, cfg.max_ops_per_assembly, cfg.seed,
                                                     cfg.mode, cfg.directions_per_range)
                continue
            status(f"counting {a.name}")
            # TooManyOperations (an InputError): uncapped and beyond the budget, refused at once
            selections[a.name] = select_operations(a, cfg.max_ops_per_assembly, cfg.seed,
                                                   cfg.mode, cfg.directions_per_range)
        keys = existing_keys(out)
        return LabelPlan(config=cfg, assemblies=assemblies, params=params, selections=selections,
                         existing_keys=keys, new_dataset=new, started=started, lock=lock,
                         duplicates=duplicate_keys(out))
    except BaseException:
        lock.release()
        raise


def selects_in_tasks(cfg: LabelConfig, assemblies: int) -> bool:
    """Whether a run selects each assembly's operations in a Ray task of its own
    (``rap.farm.prefetch``) rather than in the driver's thread: with several assemblies, unless
    ``selection_tasks`` is 0."""
    return assemblies > 1 and cfg.selection_tasks != 0


@dataclass
class Outcome:
    """What selecting one assembly found besides its jobs (``select_jobs`` fills it in)."""

    total: int | None = None  # what the selection takes, once counted (at most the plan's total)
    selected: int = 0  # operations the selection gave
    existing: int = 0  # of those, already in the dataset
    short: Shortfall | None = None  # the selection ended before its total, and why
    failed: str | None = None  # the selection itself failed: why


def select_jobs(plan: LabelPlan, assembly: Assembly, outcome: Outcome,
                stop: Callable[[], bool] = lambda: False) -> Iterator[tuple[Operation, str, int]]:
    """``(operation, key, seed)`` of every operation of ``assembly``'s selection not yet in the
    dataset, each once, lazily; counts into ``outcome``. A failing selection fails this assembly
    only (``outcome.failed``); ``stop()`` true ends it early. No Ray: the driver runs it in its
    thread (``iter_jobs``) or in Ray tasks (``rap.farm.prefetch``)."""
    fp = plan.params.fingerprint()
    seed = plan.config.seed
    existing = plan.existing_keys
    gh = assembly.geometry_hash
    seen: set[str] = set()  # this assembly's keys (its selection is distinct by construction)
    try:
        selection = plan.selections[assembly.name].resolved()  # counts a deferred one
        outcome.total = selection.total
        for op in selection:
            if stop():
                return
            outcome.selected += 1
            key = label_key(op, gh, fp, seed)
            if key in seen:
                continue
            seen.add(key)
            if key in existing:
                outcome.existing += 1
                continue
            yield op, key, label_seed(op, gh, fp, seed)
        outcome.short = selection.shortfall(outcome.selected)
    except (RapError, ValueError, ArithmeticError, RecursionError, MemoryError) as exc:
        outcome.failed = f"selecting operations failed: {_one_line(exc)}"


def record(summary: LabelSummary, name: str, outcome: Outcome) -> None:
    """Add one assembly's selection outcome to the run's summary."""
    if outcome.failed is not None:
        summary.failed.setdefault(name, outcome.failed)
    elif outcome.short is not None and name not in summary.failed:
        summary.short[name] = outcome.short


def recount(summary: LabelSummary, plan: LabelPlan, name: str, outcome: Outcome) -> bool:
    """Lower ``summary.total`` by what a selection the plan left uncounted turned out not to take;
    True when it did (call it once per assembly, after its count: ``outcome.total`` set)."""
    fewer = plan.selections[name].total - (outcome.total or 0)
    if outcome.total is None or fewer <= 0:
        return False
    summary.total -= fewer
    return True


def iter_jobs(plan: LabelPlan, summary: LabelSummary, skipped: Callable[[int], None],
              recounted: Callable[[], None] = lambda: None) -> Iterator[Job]:
    """The jobs of every selection, assembly after assembly, lazily, in this thread; skips what is
    already in the dataset and every assembly in ``summary.failed``. A failing enumeration fails
    its assembly only. ``recounted()`` is called when ``summary.total`` falls (``recount``)."""
    for a in plan.assemblies:
        outcome = Outcome()
        counted = [0, False]

        def count_existing() -> None:  # progress and summary as the skipped ones come
            if not counted[1] and outcome.total is not None:
                counted[1] = True
                if recount(summary, plan, a.name, outcome):
                    recounted()
            if outcome.existing > counted[0]:
                summary.existing += outcome.existing - counted[0]
                skipped(outcome.existing - counted[0])
                counted[0] = outcome.existing

        for op, key, seed in select_jobs(plan, a, outcome, lambda: a.name in summary.failed):
            count_existing()
            yield Job(a, op, key, seed)
        count_existing()
        record(summary, a.name, outcome)


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[-1] if text else type(exc).__name__

"""Label without Ray, in a plain process pool, for a bounded time: bursts on a borrowed machine.

    python scripts/label_burst.py A.json B.json ... --out DIR [--processes 16] [--minutes 8]
        [--trials 100] [--seed S] [--max-ops-per-assembly K] [--directions-per-range N]
        [--verify DATASET --verify-assembly A.json --verify-rows 64]
    python scripts/label_burst.py @LIST --out DIR ...   # LIST: one argument per line

It selects exactly what ``rap-farm label`` with the same options selects (``rap.labelling.selection``:
same checks, same seeded sample, same content keys and per-operation seeds) and labels it with the
same row code (``rap.labelling.rows.label_rows``), so its shards are indistinguishable from the farm's
and can be copied into the dataset that ``rap-farm label`` writes; the farm then skips them. It is
for machines where Ray is not installed (the device machine lent to some sessions, 16 cores); on
any machine with Ray, use ``rap-farm label``.

It stops submitting at the deadline, waits for the batches in flight and commits them (shards are
written atomically, as the farm writes them), so a burst can be cut at any time and resumed.
``--verify`` first relabels the first ``--verify-rows`` operations of an assembly already in
DATASET and compares successes row by row: labels must not depend on the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from multiprocessing import get_context
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.dataset import (SCHEMA_VERSION, DatasetMeta, open_dataset, rows_to_table,  # noqa: E402
                         write_geometry, write_meta, write_shard)
from rap.labelling.rows import Backend, label_rows, params_json, resolve  # noqa: E402
from rap.labelling.selection import LabelConfig, LabelSummary, iter_jobs, prepare  # noqa: E402

BATCH = 8  # operations per task
_FUNCS: dict = {}


def _init() -> None:
    b = Backend()
    resolve(b.warm_up)()
    _FUNCS["simulate"] = resolve(b.simulate)
    _FUNCS["render"] = resolve(b.render)
    _FUNCS["node"] = os.uname().nodename


def _task(assembly, ops, keys, seeds, params, pj):
    rows, _, _ = label_rows(assembly, ops, keys, seeds, params, pj,
                            simulate=_FUNCS["simulate"], render=_FUNCS["render"], node=_FUNCS["node"])
    return rows


def _batches(jobs, size):
    batch = []
    for j in jobs:
        if batch and (len(batch) == size or j.assembly.name != batch[0].assembly.name):
            yield batch
            batch = []
        batch.append(j)
    if batch:
        yield batch


def label(plan, processes: int, deadline: float, out: Path | None, flush_rows: int = 4096,
          limit: int | None = None) -> list[dict]:
    """Label the plan's jobs until ``deadline`` (monotonic); commit to ``out`` (or return rows)."""
    summary = LabelSummary(out=str(out), total=plan.total)
    pj = params_json(plan.params)
    jobs = iter_jobs(plan, summary, lambda k: None)
    if limit is not None:
        jobs = (j for _, j in zip(range(limit), jobs))
    batches = _batches(jobs, BATCH)
    buffer: list[dict] = []  # rows not yet committed (all of them when out is None)
    done, t0, last = 0, time.monotonic(), time.monotonic()

    def flush():
        if buffer and out is not None:
            write_shard(out, rows_to_table(buffer))
            buffer.clear()

    with ProcessPoolExecutor(processes, mp_context=get_context("fork"), initializer=_init) as ex:
        inflight = set()
        exhausted = False
        while True:
            while not exhausted and len(inflight) < 3 * processes and time.monotonic() < deadline:
                b = next(batches, None)
                if b is None:
                    exhausted = True
                    break
                inflight.add(ex.submit(_task, b[0].assembly, [j.operation for j in b],
                                       [j.key for j in b], [j.seed for j in b], plan.params, pj))
            if not inflight:
                break
            finished, inflight = wait(inflight, return_when=FIRST_COMPLETED)
            for f in finished:
                rows = f.result()
                buffer.extend(rows)
                done += len(rows)
            if len(buffer) >= flush_rows:
                flush()
            if time.monotonic() - last > 30:
                last = time.monotonic()
                print(f"  {done} rows, {done / (last - t0):.1f} ops/s, {len(inflight)} batches in flight",
                      flush=True)
    flush()
    dt = time.monotonic() - t0
    print(f"labelled {done} rows in {dt:.0f} s: {done / max(dt, 1e-9):.1f} ops/s on {processes} "
          f"processes ({'all done' if exhausted else 'stopped at the deadline'})", flush=True)
    return buffer


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], fromfile_prefix_chars="@")
    ap.add_argument("assemblies", nargs="*")
    ap.add_argument("--out", required=True)
    ap.add_argument("--processes", type=int, default=os.cpu_count())
    ap.add_argument("--minutes", type=float, default=8.0)
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--seed", type=int, default=20190527)
    ap.add_argument("--max-ops-per-assembly", type=int, default=None)
    ap.add_argument("--directions-per-range", type=int, default=1)
    ap.add_argument("--verify", default=None, help="a dataset to compare a relabelled sample with")
    ap.add_argument("--verify-assembly", default=None)
    ap.add_argument("--verify-rows", type=int, default=64)
    a = ap.parse_args()
    deadline = time.monotonic() + 60 * a.minutes
    common = dict(trials=a.trials, seed=a.seed, max_ops_per_assembly=a.max_ops_per_assembly or None,
                  directions_per_range=a.directions_per_range, progress=False,
                  command="scripts/label_burst.py")
    if a.verify:
        with tempfile.TemporaryDirectory() as tmp:
            plan = prepare(LabelConfig(assemblies=(a.verify_assembly,), out=tmp, **common))
            rows = label(plan, a.processes, deadline, None, limit=a.verify_rows)
        import pyarrow.compute as pc

        stored = open_dataset(a.verify).to_table(
            columns=["key", "successes"], filter=pc.field("key").isin([r["key"] for r in rows]))
        ref = dict(zip(stored["key"].to_pylist(), stored["successes"].to_pylist()))
        same = sum(ref.get(r["key"]) == r["successes"] for r in rows)
        print(f"verify: {same}/{len(rows)} relabelled rows identical to {a.verify} "
              f"({len(ref)} found there)", flush=True)
    if not a.assemblies:
        return
    out = Path(a.out)
    plan = prepare(LabelConfig(assemblies=tuple(a.assemblies), out=str(out), **common))
    print(f"{plan.total} operations selected, {plan.existing_rows} already in {out}", flush=True)
    if plan.new_dataset:
        write_meta(out, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=int(a.seed),
                                    params=json.loads(json.dumps(plan.params.to_dict())),
                                    command="scripts/label_burst.py"))
    write_geometry(out, plan.assemblies)  # as rap-farm label does
    label(plan, a.processes, deadline, out)


if __name__ == "__main__":
    from rap.errors import RapError

    try:
        main()
    except RapError as exc:  # one line, the CLI's exit status (a busy dataset: 3)
        print(f"label_burst: error: {exc}", file=sys.stderr)
        sys.exit(exc.exit_code)

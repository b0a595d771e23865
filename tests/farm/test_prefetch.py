"""Selection in parallel Ray tasks (``rap.farm.prefetch``) yields exactly ``iter_jobs``'s jobs:
the same keys, seeds and operations, the same counts of existing rows, short and failed
selections, whatever order the tasks' chunks arrive in."""

from __future__ import annotations

import pytest

from rap.enumerate import Selection, select_operations
from rap.farm.actors import unpack
from rap.farm.prefetch import parallel_jobs
from rap.labelling.selection import LabelConfig, LabelSummary, iter_jobs, prepare
from rap.seeds import DEFAULT_ROOT_SEED

from tests.farm.conftest import ASSEMBLIES
from tests.farm.standin import failing_stream

pytestmark = pytest.mark.ray

FILES = tuple(str(ASSEMBLIES / f"{n}.json") for n in ("grid", "hexagon", "rectilinear", "triangles"))


def _jobs(plan, parallel: bool, chunk: int = 7):
    summary, skipped = LabelSummary(out=plan.config.out, total=plan.total), []
    if parallel:
        jobs = list(parallel_jobs(plan, summary, skipped.append, tasks=3, chunk=chunk))
    else:
        jobs = list(iter_jobs(plan, summary, skipped.append))
    got = {(j.assembly.name, unpack(j.operation).key(j.assembly.geometry_hash), j.key, j.seed)
           for j in jobs}
    assert len(got) == len(jobs)  # each once
    assert all(isinstance(j.operation, bytes) == parallel for j in jobs)  # packed in the tasks
    return got, summary, sum(skipped)


def _config(out, files, **kw) -> LabelConfig:
    return LabelConfig(assemblies=files, out=str(out), trials=5, seed=DEFAULT_ROOT_SEED,
                       progress=False, **kw)


def test_parallel_selection_equals_the_driver_thread_s(ray_local, tmp_path):
    # grid's sample stops short of 600 of its 1,188 operations (a short selection)
    with prepare(_config(tmp_path / "a", FILES, max_ops_per_assembly=600)) as plan:
        # counted by the selections themselves, not by prepare: at most 600 each until then
        assert {s.how for s in plan.selections.values()} == {"capped"}
        assert plan.total == 2400 and plan.total_text == "up to 2400"
        some = sorted(k for _, _, k, _ in _jobs(plan, False)[0])[::5]
        plan.existing_keys = set(some)  # as if a fifth of the rows were in the dataset
        serial, s_summary, s_skipped = _jobs(plan, False)
        parallel, p_summary, p_skipped = _jobs(plan, True)
    assert parallel == serial and len(serial) > 600
    counted = sum(select_operations(a, 600, DEFAULT_ROOT_SEED).total for a in plan.assemblies)
    assert p_summary.total == s_summary.total == counted == 2360  # hexagon: all 560
    assert p_summary.existing == s_summary.existing == p_skipped == s_skipped == len(some)
    assert p_summary.short == s_summary.short and "grid" in p_summary.short
    assert p_summary.failed == s_summary.failed == {}


def test_a_failing_selection_fails_its_assembly_only(ray_local, tmp_path):
    with prepare(_config(tmp_path / "b", FILES[:3], max_ops_per_assembly=20)) as plan:
        name = plan.assemblies[1].name
        plan.selections[name] = Selection(plan.assemblies[1], "all", 5, 5, failing_stream)
        serial, s_summary, _ = _jobs(plan, False)
        parallel, p_summary, _ = _jobs(plan, True)
    assert parallel == serial and {a for a, *_ in parallel} == {plan.assemblies[0].name,
                                                                   plan.assemblies[2].name}
    assert p_summary.failed == s_summary.failed == {
        name: "selecting operations failed: enumeration exploded"}

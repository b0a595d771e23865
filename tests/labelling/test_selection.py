"""What a label run takes, decided without Ray: the dataset's lock taken by ``prepare`` (before any
read that decides what to label) and held by the plan; and a sample that stops short of
``--max-ops-per-assembly``, reported per assembly with the reason and the counts."""

from __future__ import annotations

import os
import socket

import pytest

import rap.dataset as ds
from rap.errors import InputError
from rap.enumerate import LABEL_BUDGET, Shortfall
from rap.labelling.selection import LabelConfig, LabelSummary, iter_jobs, prepare
from rap.seeds import DEFAULT_ROOT_SEED

from tests.farm.conftest import ASSEMBLIES

GRID = str(ASSEMBLIES / "grid.json")
PENTOMINO = str(ASSEMBLIES / "unseen" / "pentomino-6x10.json")


def config(out, **kw) -> LabelConfig:
    base = dict(assemblies=(GRID,), out=str(out), trials=5, seed=DEFAULT_ROOT_SEED,
                max_ops_per_assembly=3, progress=False, command="rap-farm label grid.json")
    base.update(kw)
    return LabelConfig(**base)


def test_prepare_holds_the_lock_and_a_second_prepare_is_refused(tmp_path):
    out = tmp_path / "ds"
    plan = prepare(config(out))
    assert plan.lock.held and (out / ds.LOCK_FILE).exists()
    with pytest.raises(ds.DatasetBusyError) as exc:
        prepare(config(out, max_ops_per_assembly=5))
    assert str(exc.value).startswith(
        f"{out}: another run is writing this dataset (pid {os.getpid()} on "
        f"{socket.gethostname()}, started ")
    assert ": rap-farm label grid.json); nothing was done" in str(exc.value)
    assert sorted(p.name for p in out.iterdir()) == [ds.LOCK_FILE]  # the refused run wrote nothing
    plan.release()
    assert not out.exists()  # made by prepare for the lock, empty: removed
    with prepare(config(out)) as again:
        assert again.lock.held
    assert not out.exists()


def test_a_prepare_that_fails_after_taking_the_lock_releases_it(tmp_path):
    from rap.sim.params import SimParams

    out = tmp_path / "ds"
    ds.write_meta(out, ds.DatasetMeta(schema_version=ds.SCHEMA_VERSION, root_seed=1,
                                      params=SimParams(trials=100).to_dict(), command="x"))
    with pytest.raises(InputError, match="dataset was labelled with --seed 1"):
        prepare(config(out))
    assert sorted(p.name for p in out.iterdir()) == [ds.METADATA_FILE]
    with prepare(config(out, seed=1, trials=100)) as plan:  # not held by the failed prepare
        assert plan.lock.held


def test_a_corrupt_shard_stops_prepare_with_one_line_and_no_lock_left(tmp_path):
    from tests.test_dataset import row

    out = tmp_path / "ds"
    with prepare(config(out)) as plan:
        ds.write_meta(out, ds.DatasetMeta(schema_version=ds.SCHEMA_VERSION,
                                          root_seed=DEFAULT_ROOT_SEED,
                                          params=plan.params.to_dict(), command="x"))
    (bad,) = ds.write_shard(out, ds.rows_to_table([row(0, assembly="grid")]))
    bad.write_bytes(b"garbage")
    with pytest.raises(ds.CorruptShardError, match=f"^{bad}: corrupt shard"):
        prepare(config(out))
    assert not (out / ds.LOCK_FILE).exists()


def test_a_sample_that_stops_short_says_why_with_the_counts(tmp_path):
    """`label pentomino-6x10.json --max-ops-per-assembly 3000 --trials 5`: the random disassembly
    trees stop bringing new operations (64 in a row) at 1,134 of a space of 20,796."""
    from rap.farm.driver import format_summary

    with prepare(config(tmp_path / "ds", assemblies=(PENTOMINO,),
                        max_ops_per_assembly=3000)) as plan:
        summary = LabelSummary(out=str(tmp_path / "ds"), total=plan.total)
        jobs = list(iter_jobs(plan, summary, lambda k: None))
    assert plan.total == 3000 and len(jobs) == 1134
    short = summary.short["pentomino-6x10"]
    assert (short.selected, short.asked, short.space) == (1134, 3000, 20796)
    assert short.reason.startswith("the sampler stopped after 64 random disassembly trees in a row "
                                   "brought no new operation")
    assert short.reason.endswith("the rest of the space lies in subassemblies its trees reach "
                                 "rarely")
    line = [x for x in format_summary(summary).splitlines() if x.startswith("short")]
    assert line == [f"short        pentomino-6x10: 1,134 of 3,000 operations asked (a space of "
                    f"20,796): {short.reason} (no limit labels all 20,796)"]
    # `rap-farm label` says how with its flag
    line = [x for x in format_summary(summary, no_limit="--max-ops-per-assembly 0").splitlines()
            if x.startswith("short")]
    assert line == [f"short        pentomino-6x10: 1,134 of 3,000 operations asked (a space of "
                    f"20,796): {short.reason} (--max-ops-per-assembly 0 labels all 20,796)"]


def test_samples_that_reach_their_total_say_nothing(tmp_path):
    with prepare(config(tmp_path / "ds", assemblies=(PENTOMINO, GRID),
                        max_ops_per_assembly=300)) as plan:
        summary = LabelSummary(out=str(tmp_path / "ds"), total=plan.total)
        assert len(list(iter_jobs(plan, summary, lambda k: None))) == plan.total
    assert summary.short == {}
    from rap.farm.driver import format_summary

    assert not any(x.startswith("short") for x in format_summary(summary).splitlines())


@pytest.mark.parametrize("space, why", [
    (None, f"a space of more than {LABEL_BUDGET:,}"),
    (900, "a space of 900"),
])
def test_shortfall_text(space, why):
    s = Shortfall(853, 3000, space, "because")
    assert s.describe() == f"853 of 3,000 operations asked ({why}): because"
    assert s.describe("--max-ops-per-assembly 0") == s.describe()  # nothing more to label


def test_shortfall_says_how_to_label_a_larger_counted_space():
    s = Shortfall(853, 3000, 20796, "because")
    assert s.describe() == ("853 of 3,000 operations asked (a space of 20,796): because (no limit "
                            "labels all 20,796)")
    assert s.describe("--max-ops-per-assembly 0").endswith(
        "because (--max-ops-per-assembly 0 labels all 20,796)")


def test_an_exhaustive_stream_that_ends_early_says_so():
    from rap.enumerate import Selection, enumerate_operations
    from rap.io import load_assembly

    a = load_assembly(GRID)
    ops = enumerate_operations(a)[:7]
    sel = Selection(a, "all", 10, 10, lambda: iter(ops))
    assert sel.shortfall(10) is None
    assert sel.shortfall(len(list(sel))) == Shortfall(
        7, 10, 10, "the space holds fewer distinct operations than were counted")


def test_a_plan_whose_lock_was_released_does_not_run(tmp_path):
    from rap.farm.driver import run_label

    plan = prepare(config(tmp_path / "ds"))
    plan.release()
    with pytest.raises(InputError, match="this plan's lock on the dataset was released"):
        run_label(plan.config, plan)

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from tests.model.model_fixtures import FAST_TRAIN, TINY_MODEL
from rap.errors import InputError, ParameterError
from rap.model.data.rows import InMemoryBatches, StreamingBatches, make_batches, select
from rap.model.training.train import TrainConfig, train


def _weights(result):
    return {k: v.clone() for k, v in result.model.state_dict().items()}


def test_trains_a_step_or_two_and_reports_progress(tiny_dataset):
    events = []
    r = train(tiny_dataset, model_config=TINY_MODEL, config=replace(FAST_TRAIN, epochs=1, batch_size=64),
              on_step=events.append)
    assert [e["step"] for e in events] == [1, 2, 3]  # 144 rows in batches of 64
    assert events[-1]["steps"] == 3 and 0 <= events[-1]["accuracy"] <= 1
    assert r.metrics["train"]["rows"] == 144 and "holdout" not in r.metrics
    assert r.training["class_counts"] == [96, 48]
    assert r.training["class_weights"] == pytest.approx([144 / 192, 144 / 96])  # balanced


def test_fixed_seed_is_reproducible_and_leaves_global_rng_alone(tiny_dataset):
    torch.manual_seed(123)
    state = torch.get_rng_state()
    a = _weights(train(tiny_dataset, model_config=TINY_MODEL, config=FAST_TRAIN))
    assert torch.equal(torch.get_rng_state(), state)
    b = _weights(train(tiny_dataset, model_config=TINY_MODEL, config=FAST_TRAIN))
    c = _weights(train(tiny_dataset, model_config=TINY_MODEL, config=replace(FAST_TRAIN, seed=1)))
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)


def test_streaming_batches_cover_every_row_once_reproducibly(tiny_dataset):
    sel = select(tiny_dataset, exclude=("beta",))
    mem = make_batches(sel, 0.95, 10, max_memory_mb=100)
    stream = make_batches(sel, 0.95, 10, max_memory_mb=0.2)  # 25 rows in memory at most
    assert isinstance(mem, InMemoryBatches) and isinstance(stream, StreamingBatches)
    epochs = [list(stream.epoch(np.random.default_rng(s))) for s in (0, 0, 1)]
    imgs = [np.concatenate([b[0] for b in e]) for e in epochs]
    assert len(imgs[0]) == len(mem) == 96
    assert np.array_equal(imgs[0], imgs[1]) and not np.array_equal(imgs[0], imgs[2])
    key = lambda a: sorted(x.tobytes() for x in a)  # noqa: E731
    assert key(imgs[0]) == key(mem.images)
    assert sum(int(b[1].sum()) for b in epochs[0]) == int(mem.labels.sum())


def test_streaming_training_runs(tiny_dataset):
    r = train(tiny_dataset, model_config=TINY_MODEL, config=replace(FAST_TRAIN, max_memory_mb=0.2))
    assert r.metrics["train"]["rows"] == 144


def test_unknown_holdout_and_bad_options(tiny_dataset, tmp_path):
    with pytest.raises(InputError, match="no such assembly"):
        train(tiny_dataset, holdout="delta", model_config=TINY_MODEL, config=FAST_TRAIN)
    with pytest.raises(InputError, match="no such dataset"):
        train(tmp_path / "none", model_config=TINY_MODEL, config=FAST_TRAIN)
    with pytest.raises(InputError):
        TrainConfig(epochs=0)


def test_init_starts_from_a_checkpoints_weights_and_records_it(tiny_dataset, tmp_path):
    first = train(tiny_dataset, model_config=TINY_MODEL, config=FAST_TRAIN)
    path = first.save(tmp_path / "first.pt")
    # a tiny learning rate: the fine-tuned weights stay next to the first model's, far from a
    # fresh initialisation's
    cfg = replace(FAST_TRAIN, lr=1e-9, seed=1)
    tuned = _weights(train(tiny_dataset, model_config=TINY_MODEL, config=cfg, init=path))
    fresh = _weights(train(tiny_dataset, model_config=TINY_MODEL, config=cfg))
    start = _weights(first)
    floats = [k for k in start if start[k].is_floating_point() and "running" not in k]
    assert all(torch.allclose(tuned[k], start[k], atol=1e-5) for k in floats)
    assert not all(torch.allclose(fresh[k], start[k], atol=1e-5) for k in floats)
    r = train(tiny_dataset, model_config=TINY_MODEL, config=FAST_TRAIN, init=path)
    assert r.training["init"] == {"path": str(path), "data_fingerprint": first.data_fingerprint,
                                  "command": None}
    assert train(tiny_dataset, model_config=TINY_MODEL, config=FAST_TRAIN).training["init"] is None


def test_init_with_another_network_is_one_input_error(tiny_dataset, tmp_path):
    path = train(tiny_dataset, model_config=TINY_MODEL, config=FAST_TRAIN).save(tmp_path / "a.pt")
    wider = replace(TINY_MODEL, channels=tuple(2 * c for c in TINY_MODEL.channels))
    with pytest.raises(ParameterError) as err:  # the parameter; `rap-farm train` says --init
        train(tiny_dataset, model_config=wider, config=FAST_TRAIN, init=path)
    assert err.value.parameter == "init"
    assert str(err.value) == (f"init {path}: its network differs from this recipe's in channels "
                              f"(choose the recipe and options it was trained with)")
    with pytest.raises(InputError, match="no such checkpoint"):
        train(tiny_dataset, model_config=TINY_MODEL, config=FAST_TRAIN, init=tmp_path / "none.pt")


def test_init_names_a_field_the_recipe_leaves_out():
    """The shipped model takes descriptors; a recipe without them leaves the key out of its
    dict: the message still names it (it once named nothing)."""
    from rap.model.network.checkpoint import load_checkpoint
    from rap.model.training.train import _init_checkpoint

    shipped = Path(__file__).resolve().parents[3] / "rap" / "data" / "default_model.pt"
    images_only = replace(load_checkpoint(shipped).config, descriptors=())
    with pytest.raises(ParameterError, match="differs from this recipe's in descriptors "):
        _init_checkpoint(shipped, images_only)


def test_training_with_the_rows_split_records_it(tiny_dataset):
    cfg = replace(FAST_TRAIN, calibrate=True, val_by="rows", val_fraction=0.3)
    r = train(tiny_dataset, model_config=TINY_MODEL, config=cfg)
    assert r.training["config"]["val_by"] == "rows" and r.calibration["assemblies"]
    with pytest.raises(InputError, match="val_by 'some': assemblies or rows"):
        replace(FAST_TRAIN, val_by="some")


def test_the_same_rows_in_other_shards_train_the_same_model(tmp_path):
    """Shards arrive in whatever order the farm's workers commit them: training reads rows in key
    order, so a seeded run depends on the rows, not on how they were written."""
    from tests.model.model_fixtures import synthetic_rows
    from rap.dataset import DatasetMeta, SCHEMA_VERSION, rows_to_table, write_meta, write_shard

    rows = [r for k, n in enumerate(("alpha", "beta", "gamma")) for r in synthetic_rows(n, 40, k)]
    shuffled = [rows[i] for i in np.random.default_rng(5).permutation(len(rows))]
    roots = []
    for name, order, per in (("a", rows, 40), ("b", shuffled, 7)):
        root = tmp_path / name
        write_meta(root, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=0,
                                     params={"trials": 100}, command="test"))
        for s in range(0, len(order), per):
            write_shard(root, rows_to_table(order[s:s + per]))
        roots.append(root)
    for mem in (2048.0, 0.9):  # RowStore; InMemoryBatches of a selection (the store does not fit)
        cfg = replace(FAST_TRAIN, max_memory_mb=mem)
        a, b = (_weights(train(r, model_config=TINY_MODEL, config=cfg, holdout="gamma"))
                for r in roots)
        assert all(torch.equal(a[k], b[k]) for k in a)
    from rap.model.data.rows import RowStore

    as_read = RowStore(roots[1], order="dataset")
    assert sorted(as_read.keys) == list(RowStore(roots[1]).keys) != list(as_read.keys)


class _Stop(Exception):
    pass


def _stop_at(epoch):
    def on_step(ev):
        if ev.get("epoch") == epoch:
            raise _Stop
    return on_step


def test_an_interrupted_run_resumes_bit_identically(tiny_dataset, tmp_path):
    # hflip draws from numpy's generator, dropout from torch's, Adam keeps moments, cosine the step
    cfg = replace(FAST_TRAIN, epochs=3, augment="hflip", schedule="cosine")
    whole = train(tiny_dataset, model_config=TINY_MODEL, config=cfg)
    state = tmp_path / "m.pt.resume"
    with pytest.raises(_Stop):  # stopped in the middle of the third epoch
        train(tiny_dataset, model_config=TINY_MODEL, config=cfg, resume=state, on_step=_stop_at(3))
    assert state.exists()
    events = []
    resumed = train(tiny_dataset, model_config=TINY_MODEL, config=cfg, resume=state,
                    on_step=events.append)
    assert resumed.training["resume"] == {"path": str(state), "from_epoch": 2, "replaced": False}
    assert {e["epoch"] for e in events} == {3}  # only the last epoch was trained again
    a, b = _weights(whole), _weights(resumed)
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert resumed.metrics["train"]["accuracy"] == whole.metrics["train"]["accuracy"]
    assert whole.training["resume"] is None


def test_a_state_left_by_another_run_is_replaced_not_resumed(tiny_dataset, tmp_path):
    state = tmp_path / "m.pt.resume"
    with pytest.raises(_Stop):
        train(tiny_dataset, model_config=TINY_MODEL, config=FAST_TRAIN, resume=state,
              on_step=_stop_at(2))
    other = replace(FAST_TRAIN, lr=5e-4)  # another run: its state must not be continued
    r = train(tiny_dataset, model_config=TINY_MODEL, config=other, resume=state)
    assert r.training["resume"] == {"path": str(state), "from_epoch": 0, "replaced": True}
    fresh = train(tiny_dataset, model_config=TINY_MODEL, config=other)
    a, b = _weights(r), _weights(fresh)
    assert all(torch.equal(a[k], b[k]) for k in a)
    # a held-out assembly is another run too; a thread count is not
    held = train(tiny_dataset, model_config=TINY_MODEL, config=other, resume=state, holdout="beta")
    assert held.training["resume"]["replaced"]
    again = train(tiny_dataset, model_config=TINY_MODEL, config=replace(other, num_threads=2),
                  resume=state, holdout="beta")
    assert again.training["resume"]["from_epoch"] == other.epochs


def test_a_file_that_is_not_a_state_is_one_input_error(tiny_dataset, tmp_path):
    state = tmp_path / "m.pt.resume"
    state.write_text("not a state")
    with pytest.raises(InputError, match="not a training state"):
        train(tiny_dataset, model_config=TINY_MODEL, config=FAST_TRAIN, resume=state)


def _with_copies(tmp_path, name, rows, copies, prefix):
    """A dataset of ``rows`` plus ``copies`` (rows with keys already there) in shards renamed
    ``part-<prefix>…``: the copies' shards sort before the others' (``-``) or after them (``z``)."""
    from rap.dataset import DatasetMeta, SCHEMA_VERSION, rows_to_table, write_meta, write_shard

    root = tmp_path / name
    write_meta(root, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=0,
                                 params={"trials": 100}, command="test"))
    for part in (rows[:60], rows[60:]):
        write_shard(root, rows_to_table(part))
    if copies:
        for f in write_shard(root, rows_to_table(copies)):
            f.rename(f.with_name(f"part-{prefix}{f.name[5:]}"))
    return root


def test_duplicated_keys_are_each_one_row_the_first_by_shard_path(tmp_path):
    """Keys stored twice (two writers before the lock) are one row each, the first by shard path
    then row, whichever reader: the clean dataset's rows, fingerprint and model when the clean
    rows come first, the copies' scores when the copies do."""
    from tests.model.model_fixtures import synthetic_rows
    from rap.dataset import duplicate_keys, read_table
    from rap.model.data.rows import RowStore, data_fingerprint

    rows = [r for k, n in enumerate(("alpha", "beta", "gamma")) for r in synthetic_rows(n, 40, k)]
    copies = [dict(r, score=0.0, successes=0) for r in rows[::3]]  # a wrong pick shows
    clean = _with_copies(tmp_path, "clean", rows, [], "")
    last = _with_copies(tmp_path, "last", rows, copies, "z")
    first = _with_copies(tmp_path, "first", rows, copies, "-")
    scores = {r["key"]: r["score"] for r in rows}
    copied = {r["key"] for r in copies}
    for root, want in ((last, scores),
                       (first, {k: 0.0 if k in copied else v for k, v in scores.items()})):
        assert duplicate_keys(root).rows == len(copies) == 40
        kept = read_table(root, ["key", "score"], unique=True)
        assert dict(zip(kept["key"].to_pylist(), kept["score"].to_pylist())) == want
        store = RowStore(root)
        assert len(store) == 120 and dict(zip(store.keys.tolist(), store.scores.tolist())) == want
        assert select(root).count() == 120
        for mb in (100, 0.2):  # in memory, streamed
            batches = make_batches(select(root), 0.95, 10, max_memory_mb=mb)
            got = sorted(int(x) for b in batches.epoch(np.random.default_rng(0)) for x in b[2])
            assert got == sorted(int(round(s * 100)) for s in want.values())
    assert data_fingerprint(select(last)) == data_fingerprint(select(clean))
    cfg = replace(FAST_TRAIN, max_memory_mb=2048.0)
    trained = train(last, model_config=TINY_MODEL, config=cfg)
    assert trained.metrics["train"]["rows"] == 120 and trained.training["corpus"]["rows"] == 120
    a = _weights(train(clean, model_config=TINY_MODEL, config=cfg))
    assert all(torch.equal(a[k], v) for k, v in _weights(trained).items())

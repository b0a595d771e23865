"""Fixtures of the model tests; the data they build is defined in ``model_fixtures``."""

import pytest
import torch

from tests.model.model_fixtures import write_synthetic


@pytest.fixture(autouse=True)
def _one_thread():
    old = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(old)


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory):
    """Three assemblies x 48 rows, two shards each."""
    return write_synthetic(tmp_path_factory.mktemp("tiny"))


@pytest.fixture(scope="session")
def learnable_dataset(tmp_path_factory):
    """Three assemblies x 160 rows: enough for the rule to be learnt across assemblies."""
    return write_synthetic(tmp_path_factory.mktemp("learnable"), n=160, seed=1)


@pytest.fixture(scope="session")
def family_dataset(tmp_path_factory):
    """Four assemblies in two families (plus a reference one): for family folds."""
    return write_synthetic(tmp_path_factory.mktemp("families"),
                           names=("alpha", "beta", "gamma", "delta", "ref"), n=96, seed=2,
                           families={"alpha": "walls", "beta": "walls", "gamma": "pegs",
                                     "delta": "pegs", "ref": "reference"})


@pytest.fixture(scope="session")
def real_dataset(tmp_path_factory):
    """Operations of two reference assemblies with made-up scores, stored as `label` would."""
    import json

    from rap.dataset import SCHEMA_VERSION, DatasetMeta, rows_to_table, write_meta, write_shard
    from rap.enumerate import enumerate_operations
    from rap.io import load_assembly
    from rap.operation import subset_key
    from rap.render.images import render_pair
    import rap

    root = tmp_path_factory.mktemp("real") / "ds"
    write_meta(root, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=1,
                                 params={"trials": 100}, command="test"))
    data = rap.__file__.rsplit("/", 1)[0] + "/data/assemblies"
    for name in ("hexagon", "rectilinear"):
        a = load_assembly(f"{data}/{name}.json")
        rows = []
        for i, op in enumerate(enumerate_operations(a, "online")[:40]):
            s = 100 if len(op.moving) == 1 else 80
            rows.append({"key": f"{name}-{i}", "assembly": name, "geometry_hash": a.geometry_hash,
                         "subassembly": subset_key(op.subassembly), "moving": subset_key(op.moving),
                         "fixed": subset_key(op.fixed), "direction_x": op.direction[0],
                         "direction_y": op.direction[1], "score": s / 100, "successes": s,
                         "trials": 100, "image": render_pair(a, op), "seed": i,
                         "params": json.dumps({"trials": 100}), "code_version": "test",
                         "node": "test", "family": "reference", "direction_index": 0})
        write_shard(root, rows_to_table(rows))
    return root

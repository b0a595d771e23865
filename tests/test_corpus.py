"""The committed corpus ``datasets/corpus``: a small slice read by pandas, Ray Data and rap.dataset.

Only a few shards are read (CI does not load the whole corpus); what the slice shows is the format:
the schema, 100 trials, a family on every row, the image pairs, the assembly files next to it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rap.dataset import SCHEMA, decode_images, read_meta
from tests.farm.conftest import ray_local  # noqa: F401  (a fixture: the shared local Ray)

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "datasets" / "corpus"
SHARDS = sorted(CORPUS.glob("*/part-*.parquet"))

pytestmark = pytest.mark.skipif(not SHARDS, reason="no corpus shards in this checkout")


@pytest.fixture(scope="module")
def slice_files():
    by_family = {}
    for f in SHARDS:  # one shard of each of a few assemblies, several families
        fam = f.parent.name.rsplit("-s", 1)[0]
        by_family.setdefault(fam, f)
    return sorted(by_family.values())[:6]


def test_pandas_reads_the_slice(slice_files):
    import pandas as pd

    df = pd.concat([pd.read_parquet(f) for f in slice_files])
    assert set(SCHEMA.names) <= set(df.columns)
    assert (df["trials"] == 100).all() and df["family"].notna().all()
    assert ((df["score"] >= 0) & (df["score"] <= 1)).all()
    assert df["key"].is_unique
    assert set(df["direction_index"]) <= {0, 1, 2}


def test_rap_dataset_reads_the_slice_and_the_metadata(slice_files):
    import pyarrow.dataset as pads

    t = pads.dataset([str(f) for f in slice_files], schema=SCHEMA, format="parquet").to_table()
    images = decode_images(t.column("image"))
    assert images.shape == (t.num_rows, 2, 64, 64) and images.dtype == np.uint8
    assert images.max() == 255  # fixed parts drawn
    meta = read_meta(CORPUS)
    assert meta.schema_version == 2 and meta.params["trials"] == 100
    for name in {f.parent.name for f in slice_files}:
        doc = json.loads((CORPUS / "_assemblies" / f"{name}.json").read_text()) \
            if (CORPUS / "_assemblies" / f"{name}.json").exists() else None
        if doc is not None:  # every assembly ships its geometry; the six are family "reference"
            reference = (ROOT / "assemblies" / f"{name}.json").exists()
            assert doc["name"] == name
            assert doc.get("family", "reference") == ("reference" if reference else name.rsplit("-s", 1)[0])


@pytest.mark.ray
def test_ray_data_reads_the_slice(slice_files, ray_local):
    import ray

    started = not ray.is_initialized()
    if started:
        ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    try:
        ds = ray.data.read_parquet([str(f) for f in slice_files])
        # the whole (limited) stream: take(3) returns while Ray Data's executor thread still
        # winds down, and a ray.shutdown() racing it makes Ray quick-exit the process
        rows = ds.limit(3).take_all()
        assert len(rows) == 3 and rows[0]["trials"] == 100 and len(rows[0]["image"]) == 8192
    finally:
        if started:
            ray.shutdown()

"""rap.dataset: schema 2 rows, atomic shards, and schema-1 shards still readable."""

from __future__ import annotations

import pyarrow as pa
import pyarrow.parquet as pq

from rap.dataset import SCHEMA, decode_images, open_dataset, rows_to_table, write_shard


def row(i: int, **extra) -> dict:
    r = {"key": f"k{i}", "assembly": "a", "geometry_hash": "g", "subassembly": "x,y", "moving": "x",
         "fixed": "y", "direction_x": 1.0, "direction_y": 0.0, "score": 0.5, "successes": 1,
         "trials": 2, "image": bytes([i % 256]) * 8192, "seed": i, "params": "{}",
         "code_version": "0", "node": "n"}
    r.update(extra)
    return r


def test_rows_round_trip_with_family_and_direction_index(tmp_path):
    write_shard(tmp_path, rows_to_table([row(0, family="wall", direction_index=2), row(1)]))
    t = open_dataset(tmp_path).to_table().sort_by("key")
    assert t.column("family").to_pylist() == ["wall", None]
    assert t.column("direction_index").to_pylist() == [2, None]
    assert decode_images(t.column("image"))[0, 0, 0, 0] == 0


def test_schema_1_shards_read_with_null_new_columns(tmp_path):
    v1 = pa.schema([f for f in SCHEMA if f.name not in ("family", "direction_index")])
    t = rows_to_table([row(3)]).select(v1.names).cast(v1)
    (tmp_path / "a").mkdir()
    pq.write_table(t, tmp_path / "a" / "part-old.parquet")
    back = open_dataset(tmp_path).to_table()
    assert back.num_rows == 1 and back.column("family").to_pylist() == [None]


def test_geometry_kept_beside_the_rows_once_and_replaced_when_other(tmp_path):
    from pathlib import Path

    from rap.dataset import GEOMETRY_DIR, write_geometry
    from rap.io import load_assembly

    root = Path(__file__).resolve().parents[1] / "assemblies"
    grid, hexagon = load_assembly(root / "grid.json"), load_assembly(root / "hexagon.json")
    assert write_geometry(tmp_path, [grid, hexagon]) == 2
    kept = tmp_path / GEOMETRY_DIR / "grid.json"
    assert load_assembly(kept).geometry_hash == grid.geometry_hash
    before = kept.stat().st_mtime_ns
    assert write_geometry(tmp_path, [grid]) == 0 and kept.stat().st_mtime_ns == before
    kept.write_text("{not json")  # unreadable: written again
    assert write_geometry(tmp_path, [grid]) == 1
    assert load_assembly(kept).geometry_hash == grid.geometry_hash
    (tmp_path / GEOMETRY_DIR / "hexagon.json").write_bytes(kept.read_bytes())  # other geometry
    assert write_geometry(tmp_path, [hexagon]) == 1
    assert load_assembly(tmp_path / GEOMETRY_DIR / "hexagon.json").geometry_hash == hexagon.geometry_hash

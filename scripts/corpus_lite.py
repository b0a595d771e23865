"""Carry a dataset without its images and render them again where it is unpacked.

    python scripts/corpus_lite.py pack DATASET OUT_DIR       # rows minus images, + image hashes
    python scripts/corpus_lite.py unpack LITE_DIR DATASET [--processes N]

A dataset's images are most of its bytes (the committed corpus: about 70 of 74 MB) and are a pure
function of its geometry: ``rap.render.images.render_pair`` of the row's assembly and operation.
``pack`` writes every column but ``image`` plus a 16-byte BLAKE2b digest of each image, and the
assembly files; ``unpack`` renders the pairs again in a process pool, checks every one against its
digest (the count of mismatches is printed; a mismatch keeps the rendered image) and writes a
dataset that ``rap-farm train``/``evaluate`` read like the original. Used to move the corpus to a
borrowed GPU machine whose transfer limit is smaller than the corpus.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

LITE = "rows.parquet"


def _digest(b: bytes) -> bytes:
    return hashlib.blake2b(b, digest_size=16).digest()


def pack(dataset: Path, out: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from rap.dataset import METADATA_FILE, open_dataset

    t = open_dataset(dataset).to_table()
    digests = pa.array([_digest(b) for b in t.column("image").to_pylist()], pa.binary(16))
    t = t.drop(["image"]).append_column("image_digest", digests)
    out.mkdir(parents=True, exist_ok=True)
    pq.write_table(t, out / LITE, compression="zstd", compression_level=19)
    shutil.copy(dataset / METADATA_FILE, out / METADATA_FILE)
    shutil.copytree(dataset / "_assemblies", out / "_assemblies", dirs_exist_ok=True)
    print(f"{t.num_rows} rows -> {out / LITE} ({(out / LITE).stat().st_size / 2**20:.1f} MiB)")


_ASSEMBLIES: dict = {}  # per worker process: name -> Assembly
_PARAMS: dict = {}  # params JSON text -> SimParams


def _render(args):
    root, name, moving, fixed, dx, dy, params_json = args
    from rap.io import load_assembly
    from rap.operation import Operation
    from rap.render.images import render_pair
    from rap.sim.params import SimParams

    a = _ASSEMBLIES.get(name)
    if a is None:
        a = _ASSEMBLIES[name] = load_assembly(Path(root) / "_assemblies" / f"{name}.json")
    params = _PARAMS.get(params_json)
    if params is None:
        params = _PARAMS[params_json] = SimParams.from_dict(json.loads(params_json))
    op = Operation(frozenset(moving.split(",")), frozenset(fixed.split(",")), (dx, dy))
    return render_pair(a, op, params=params, size=64).astype("uint8").tobytes()


def unpack(lite: Path, dataset: Path, processes: int | None) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from rap.dataset import METADATA_FILE, write_shard

    t0 = time.perf_counter()
    t = pq.read_table(lite / LITE)
    cols = [t.column(c).to_pylist() for c in ("assembly", "moving", "fixed", "direction_x",
                                               "direction_y", "params")]
    jobs = [(str(lite), *row) for row in zip(*cols)]
    with ProcessPoolExecutor(processes) as ex:
        images = list(ex.map(_render, jobs, chunksize=256))
    bad = sum(_digest(b) != d for b, d in zip(images, t.column("image_digest").to_pylist()))
    t = t.drop(["image_digest"]).append_column("image", pa.array(images, pa.binary()))
    dataset.mkdir(parents=True, exist_ok=True)
    shutil.copy(lite / METADATA_FILE, dataset / METADATA_FILE)
    shutil.copytree(lite / "_assemblies", dataset / "_assemblies", dirs_exist_ok=True)
    from rap.dataset import SCHEMA

    write_shard(dataset, t.select(SCHEMA.names).cast(SCHEMA))
    print(f"{t.num_rows} rows rendered in {time.perf_counter() - t0:.0f} s; {bad} images differ "
          f"from the originals' digests", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("pack")
    p.add_argument("dataset", type=Path)
    p.add_argument("out", type=Path)
    u = sub.add_parser("unpack")
    u.add_argument("lite", type=Path)
    u.add_argument("dataset", type=Path)
    u.add_argument("--processes", type=int, default=None)
    a = ap.parse_args()
    if a.cmd == "pack":
        pack(a.dataset, a.out)
    else:
        unpack(a.lite, a.dataset, a.processes)


if __name__ == "__main__":
    main()

"""Build, label and describe the committed corpus ``datasets/corpus`` (see datasets/README.md).

    python scripts/make_corpus.py assemblies   # the generated assemblies -> datasets/corpus/_assemblies
    python scripts/make_corpus.py plan         # rows the corpus will hold, per family (no labelling)
    python scripts/make_corpus.py label [--workers N] [--address ADDR]   # resumable
    python scripts/make_corpus.py card         # the card's figures -> datasets/README.md (between markers)

Everything is deterministic: family ``F`` contributes the assemblies ``generate(F, seed)`` for
``seed`` in ``range(SEEDS)`` (options drawn per seed, see ``rap.geometry.families``); ``label`` runs
two ``rap-farm label`` commands into the same dataset (same root seed, 100 trials):

1. the generated assemblies, interleaved across families (seed-major order, so a partial corpus
   stays balanced), a seeded sample of ``K`` operations each, ``DIRECTIONS`` per range;
2. every operation of the six reference assemblies, ``DIRECTIONS`` per range.

Rows are content-keyed: rerunning ``label`` (after an interruption, in a later session, on a
cluster with ``--address``) adds exactly what is missing and nothing twice. The assembly files are
kept next to the shards (``_assemblies/``: readers skip paths starting with ``_``), so the corpus
can be re-rendered in other image formats without regenerating anything.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CORPUS = ROOT / "datasets" / "corpus"
ASSEMBLY_DIR = CORPUS / "_assemblies"
REFERENCE = sorted((ROOT / "assemblies").glob("*.json"))
SEEDS = 36  # assemblies per family
K = 420  # operations per generated assembly (all of them when its space is smaller)
DIRECTIONS = 3  # operations per merged direction range: the middle + 2 seeded inside it
ROOT_SEED = 20190527  # rap.seeds.DEFAULT_ROOT_SEED
TRIALS = 100


def generated_paths() -> list[Path]:
    """The generated assembly files in labelling order (seed-major across families)."""
    from rap.geometry.families import FAMILIES, assembly_name

    return [ASSEMBLY_DIR / f"{assembly_name(f, s)}.json" for s in range(SEEDS) for f in FAMILIES]


def make_assemblies() -> None:
    from rap.assembly import assembly_to_json
    from rap.geometry.families import FAMILIES, generate

    ASSEMBLY_DIR.mkdir(parents=True, exist_ok=True)
    n = 0
    for path in generated_paths():
        family, seed = path.stem.rsplit("-s", 1)
        a = generate(family, int(seed))
        assert a.name == path.stem and a.family == family, (a.name, a.family)
        text = json.dumps(assembly_to_json(a), separators=(",", ":")) + "\n"
        if not path.exists() or path.read_text() != text:
            tmp = path.with_suffix(".tmp")
            tmp.write_text(text)
            tmp.replace(path)
            n += 1
    for path in REFERENCE:  # the six too, so that the corpus carries all of its geometry
        target = ASSEMBLY_DIR / path.name
        if not target.exists() or target.read_bytes() != path.read_bytes():
            target.write_bytes(path.read_bytes())
            n += 1
    print(f"{len(FAMILIES) * SEEDS} generated and {len(REFERENCE)} reference assemblies in "
          f"{ASSEMBLY_DIR.relative_to(ROOT)} ({n} written)")


def plan() -> None:
    from rap.enumerate import select_operations
    from rap.io import load_assembly

    per: dict[str, list[int]] = {}
    for path in generated_paths():
        a = load_assembly(path)
        per.setdefault(a.family, []).append(select_operations(a, K, ROOT_SEED,
                                                              directions_per_range=DIRECTIONS).total)
    for path in REFERENCE:
        a = load_assembly(path)
        per.setdefault("reference", []).append(
            select_operations(a, None, ROOT_SEED, directions_per_range=DIRECTIONS).total)
    print(f"{'family':12s} {'assemblies':>10s} {'rows':>8s} {'min':>5s} {'max':>6s}")
    for fam, rows in per.items():
        print(f"{fam:12s} {len(rows):10d} {sum(rows):8d} {min(rows):5d} {max(rows):6d}")
    print(f"{'total':12s} {sum(len(v) for v in per.values()):10d} "
          f"{sum(sum(v) for v in per.values()):8d}")


def label(workers: int | None, address: str | None) -> None:
    common = ["--out", str(CORPUS), "--seed", str(ROOT_SEED), "--trials", str(TRIALS),
              "--directions-per-range", str(DIRECTIONS), "--flush-rows", "4096",
              "--flush-seconds", "300", "--quiet"]
    if workers:
        common += ["--workers", str(workers)]
    if address:
        common += ["--address", address]
    runs = [[*map(str, generated_paths()), "--max-ops-per-assembly", str(K)],
            [*map(str, REFERENCE), "--max-ops-per-assembly", "0"]]
    for args in runs:
        cmd = ["rap-farm", "label", *args, *common]
        print("$ rap-farm label ... " + " ".join(args[-2:] + common), flush=True)
        rc = subprocess.call(cmd)
        if rc:
            sys.exit(rc)


CARD = ROOT / "datasets" / "README.md"
BEGIN, END = "<!-- corpus-card:begin -->", "<!-- corpus-card:end -->"


def card() -> None:
    """The card's figures, as they are in the committed corpus: totals, the simulator parameters'
    fingerprint, the labelling code's version, per-family rows, assemblies, high fraction and a
    10-bin score histogram. Printed, and written into datasets/README.md between the markers."""
    import numpy as np
    import pyarrow.compute as pc

    from rap.dataset import open_dataset, read_meta
    from rap.sim.params import SimParams

    t = open_dataset(CORPUS).to_table(columns=["assembly", "family", "score", "trials",
                                                "direction_index", "code_version"])
    fam = np.array(t.column("family").to_pylist(), dtype=object)
    names = np.array(t.column("assembly").to_pylist(), dtype=object)
    score = t.column("score").to_numpy()
    meta = read_meta(CORPUS)
    files = sorted(CORPUS.glob("*/part-*.parquet"))
    size = sum(f.stat().st_size for f in files)
    params = SimParams.from_dict(dict(meta.params))
    lines = [
        f"- rows: **{t.num_rows:,}** from **{len(set(names.tolist()))}** assemblies in "
        f"**{len(set(fam.tolist()))}** families (`reference`: the six); "
        f"{int((fam != 'reference').sum()):,} rows of generated assemblies",
        f"- trials per operation: {sorted(set(t.column('trials').to_pylist()))}; high (score >= "
        f"0.95): {np.mean(score >= 0.95):.3f}",
        f"- directions: {', '.join(f'index {k}: {v:,}' for k, v in sorted(zip(*np.unique(t.column('direction_index').to_numpy(), return_counts=True))))} "
        "(0: the middle of the range)",
        f"- shards: {len(files)} Parquet files, {size / 2 ** 20:.1f} MiB in all, the largest "
        f"{max(f.stat().st_size for f in files) / 2 ** 20:.2f} MiB",
        f"- root seed {meta.root_seed}; simulator parameters' fingerprint "
        f"`{params.fingerprint()}` (`rap.sim.params.SimParams()`, 100 trials); schema version "
        f"{meta.schema_version}; labelled by rap-farm "
        f"{', '.join(sorted(set(t.column('code_version').to_pylist())))}",
        "",
        "| family | assemblies | rows | high (>= 0.95) | rows per score bin [0, 0.1) ... [0.9, 1] |",
        "|---|---:|---:|---:|---|",
    ]
    for f in sorted(set(fam.tolist())):
        sel = fam == f
        h = np.histogram(score[sel], bins=10, range=(0, 1))[0]
        lines.append(f"| {f} | {len(set(names[sel].tolist()))} | {int(sel.sum()):,} | "
                     f"{np.mean(score[sel] >= 0.95):.2f} | {' '.join(str(int(x)) for x in h)} |")
    text = "\n".join(lines)
    print(text)
    doc = CARD.read_text()
    if BEGIN in doc and END in doc:
        head, rest = doc.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        CARD.write_text(f"{head}{BEGIN}\n{text}\n{END}{tail}")
        print(f"\nwrote the figures into {CARD.relative_to(ROOT)}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("step", choices=["assemblies", "plan", "label", "card"])
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--address", default=None)
    args = ap.parse_args(argv)
    if args.step == "assemblies":
        make_assemblies()
    elif args.step == "plan":
        plan()
    elif args.step == "label":
        label(args.workers, args.address)
    else:
        card()


if __name__ == "__main__":
    main()

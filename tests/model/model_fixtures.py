"""Named tiny fixtures for the model tests (used through conftest.py and imported by name): synthetic datasets in the real Arrow schema.

The rule the synthetic data follows: the moving block (grey 255) is either wide (20-30 px, score
1.0: "high") or narrow (4-10 px, score in [0.2, 0.9]: "not high"); it starts near the top (channel
0) and ends resting on the fixed block (grey 128, channel 1). Assemblies differ in the fixed
block's height and width, so a model must learn the rule, not the assembly.
"""

from __future__ import annotations

import json

import numpy as np
import torch

from rap.dataset import DatasetMeta, SCHEMA_VERSION, rows_to_table, write_meta, write_shard
from rap.model.network.cnn import ModelConfig
from rap.model.training.train import TrainConfig

TINY_MODEL = ModelConfig(channels=(4, 8, 8, 8), hidden=(32, 16, 8), dropout=0.1)
# big enough to learn the synthetic rule from any seed (mean held-out accuracy 0.95-0.98 over
# seeds 0-3 at 6 epochs; TINY_MODEL fails on some seeds)
LEARN_MODEL = ModelConfig(channels=(8, 16, 16, 16), hidden=(32, 16, 8), dropout=0.1)
FAST_TRAIN = TrainConfig(epochs=2, batch_size=16, seed=0, device="cpu", num_threads=1)
ASSEMBLIES = {"alpha": (10, 40), "beta": (14, 48), "gamma": (8, 32)}  # fixed block height, width


def synthetic_image(rng: np.random.Generator, wide: bool, fixed_h: int, fixed_w: int) -> np.ndarray:
    img = np.zeros((2, 64, 64), dtype=np.uint8)
    w = int(rng.integers(20, 31)) if wide else int(rng.integers(4, 11))
    h = int(rng.integers(6, 12))
    fx0 = int(rng.integers(2, 64 - fixed_w - 1))
    top = 62 - fixed_h
    mx0 = int(np.clip(fx0 + fixed_w // 2 - w // 2 + rng.integers(-3, 4), 0, 64 - w))
    for c in (0, 1):
        img[c, top:62, fx0:fx0 + fixed_w] = 128
    start_y = int(rng.integers(2, 8))
    img[0, start_y:start_y + h, mx0:mx0 + w] = 255
    img[1, top - h:top, mx0:mx0 + w] = 255
    return img


def synthetic_rows(name: str, n: int, seed: int, family: str | None = None) -> list[dict]:
    fixed_h, fixed_w = ASSEMBLIES.get(name, (12, 40))
    rng = np.random.default_rng(seed)
    ghash = f"geom-{name}"
    rows = []
    for i in range(n):
        wide = bool(i % 3 == 0)  # imbalanced: a third high
        score = 1.0 if wide else float(rng.integers(20, 91)) / 100
        rows.append({"key": f"{name}-{seed}-{i:05d}", "assembly": name, "geometry_hash": ghash,
                     "subassembly": "a,b", "moving": "a", "fixed": "b", "direction_x": 0.0,
                     "direction_y": -1.0, "score": score, "successes": int(round(score * 100)),
                     "trials": 100, "image": synthetic_image(rng, wide, fixed_h, fixed_w),
                     "seed": i, "params": json.dumps({"trials": 100}), "code_version": "test",
                     "node": "test", "family": family})
    return rows


def write_synthetic(root, names=("alpha", "beta", "gamma"), n: int = 48, shards: int = 2,
                    seed: int = 0, families: dict | None = None):
    """A dataset directory with ``n`` rows per assembly in ``shards`` shards each; ``families``
    maps assembly names to a family (None: no family, as in schema-1 data)."""
    write_meta(root, DatasetMeta(schema_version=SCHEMA_VERSION, root_seed=seed,
                                 params={"trials": 100}, command="test"))
    for k, name in enumerate(names):
        rows = synthetic_rows(name, n, seed * 1000 + k, (families or {}).get(name))
        per = -(-n // shards)
        for s in range(0, n, per):
            write_shard(root, rows_to_table(rows[s:s + per]))
    return root

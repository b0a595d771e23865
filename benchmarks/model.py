"""Robustness CNN throughput: parameters, training samples/s, batched inference operations/s.

    /work/venv/bin/python benchmarks/model.py [--threads 2] [--seconds 5] [--device cpu]
        [--channels 16 32 64 64] [--hidden 256 128 64]

Training: Adam steps on random uint8 image pairs in batches of 64 (what `rap-farm train` does per
batch, without the data loading). Inference: ``TorchPredictor.prob_high`` — one batch per planning step
holding all of the step's candidate operations — at several batch sizes.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from rap.model.network.checkpoint import save_checkpoint
from rap.model.network.cnn import ModelConfig, RobustnessCNN
from rap.model.inference.torch_engine import TorchPredictor


def rate(fn, items_per_call: int, seconds: float) -> float:
    fn()  # warm-up
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        fn()
        n += items_per_call
    return n / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--batch-size", type=int, default=64)
    ap.add_argument("--channels", type=int, nargs=4, default=list(ModelConfig.channels))
    ap.add_argument("--hidden", type=int, nargs=3, default=list(ModelConfig.hidden))
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    device = torch.device(args.device)
    cfg = ModelConfig(channels=tuple(args.channels), hidden=tuple(args.hidden))
    model = RobustnessCNN(cfg).to(device)
    print(f"robustness CNN: channels {list(cfg.channels)}, hidden {list(cfg.hidden)}, "
          f"{model.num_parameters():,} parameters; device {device}, {args.threads} torch threads")

    rng = np.random.default_rng(0)
    x = torch.from_numpy(rng.integers(0, 256, (args.batch_size, 2, 64, 64), dtype=np.uint8)).to(device)
    y = torch.from_numpy(rng.integers(0, 2, args.batch_size)).to(device)
    opt = torch.optim.Adam(model.parameters())
    w = torch.tensor([0.75, 1.5], device=device)

    def step():
        loss = F.cross_entropy(model(x), y, weight=w)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        if device.type == "cuda":
            torch.cuda.synchronize()

    train_rate = rate(step, args.batch_size, args.seconds)
    print(f"training: {train_rate:,.0f} samples/s (batch {args.batch_size}); an epoch over "
          f"10,000 rows takes {10_000 / train_rate:.0f} s")

    with tempfile.TemporaryDirectory() as tmp:
        path = save_checkpoint(Path(tmp) / "bench.pt", model.cpu(), threshold=0.95,
                               data_fingerprint="benchmark", assemblies=[], image_stats={},
                               metrics={}, training={})
        predictor = TorchPredictor.load(path, device=args.device)
    for n in (1, 4, 16, 64, 256, 1024):
        images = rng.integers(0, 256, (n, 2, 64, 64), dtype=np.uint8)
        r = rate(lambda: predictor.prob_high(images), n, args.seconds / 2)
        print(f"inference, batch {n:>3}: {r:>9,.0f} operations/s  ({1e3 * n / r:6.2f} ms a batch)")


if __name__ == "__main__":
    main()

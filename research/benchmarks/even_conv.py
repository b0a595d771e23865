"""Convolutions that skip the rows the pooling drops: the forward pass with and without, one run.

Both inference engines compute only the even rows and columns of each convolution's output that
the floor 2x2 max-pooling reads (``rap.model.network.cnn._even_conv``, ``rap.model.inference.numpy_engine._conv_nhwc``).
This times the shipped network both ways, interleaved (the best of seven passes over 256 pairs per
batch size), and prints ms per operation and the ratio, with the largest difference of the logits.

    python -m research.benchmarks.even_conv [--model PATH]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

BATCHES = (4, 8, 16, 64)


def best_ms(f, images, descriptors, batch: int, best: float) -> float:
    n, t = 0, time.perf_counter()
    while n < len(images):
        f(images[n:n + batch], descriptors[n:n + batch])
        n += batch
    return min(best, (time.perf_counter() - t) / n * 1e3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default=str(ROOT / "rap" / "data" / "default_model.pt"))
    args = ap.parse_args()
    import numpy as np
    import torch

    import rap.model.inference.numpy_engine as fastcnn
    from rap.model.inference.torch_engine import TorchPredictor

    rng = np.random.default_rng(0)
    images = (rng.random((256, 2, 64, 64)) < 0.3).astype(np.uint8) * 255
    descriptors = rng.random((256, 12)).astype(np.float32)

    fast = fastcnn.load_numpy_predictor(args.model)
    even_conv = fastcnn._conv_nhwc

    def numpy_full(x, d):
        fastcnn._conv_nhwc = lambda a, w, pad, even=False: even_conv(a, w, pad)
        try:
            return fast.outputs(x, d)
        finally:
            fastcnn._conv_nhwc = even_conv

    net = TorchPredictor.load(args.model).model.eval()
    k = len(net.config.descriptors)

    def torch_even(x, d):
        return net(torch.from_numpy(x), torch.from_numpy(d[:, :k]) if k else None)

    def torch_full(x, d):
        h = torch.from_numpy(x).float().div_(255.0).contiguous(memory_format=torch.channels_last)
        h = net.features(h).flatten(1)
        if k:
            h = torch.cat([h, net.descriptor_norm(torch.from_numpy(d[:, :k]))], dim=1)
        return net.head(h)

    engines = {"numpy": (numpy_full, fast.outputs), "torch": (torch_full, torch_even)}
    with torch.inference_mode():
        for name, (full, even) in engines.items():
            diff = float(np.abs(np.asarray(full(images, descriptors), np.float64)
                                - np.asarray(even(images, descriptors), np.float64)).max())
            res: dict = {}
            for _ in range(7):
                for label, f in (("full", full), ("even", even)):
                    for b in BATCHES:
                        res[label, b] = best_ms(f, images, descriptors, b, res.get((label, b), 9e9))
            print(f"{name}: largest logit difference {diff:.1e}")
            for b in BATCHES:
                print(f"  batch {b:3d}: full {res['full', b]:.3f} ms/operation, even "
                      f"{res['even', b]:.3f}, full / even {res['full', b] / res['even', b]:.2f}")


if __name__ == "__main__":
    main()

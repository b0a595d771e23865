"""What the geometric descriptors cost beside the images: per operation, in one run.

    python -m research.benchmarks.descriptors [--repeats 3]

For every online operation of the six reference assemblies (middle directions): the descriptors of
``rap.model.data.descriptors`` (a fresh ``DescriptorContext`` per assembly, its NDBG included, as a
planner pays it once per assembly) against ``rap.render.images.render_pair``, the images every model
takes. Interleaved repeats; prints milliseconds per operation and the ratio.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import rap
from rap.enumerate import enumerate_operations
from rap.io import load_assembly
from rap.model.data.descriptors import DescriptorContext, descriptors_for
from rap.render.images import render_pair

NAMES = ("hexagon", "mixed-square", "pentagons", "rectilinear", "grid", "triangles")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    data = Path(rap.__file__).resolve().parent / "data" / "assemblies"
    work = []
    for name in NAMES:
        asm = load_assembly(data / f"{name}.json")
        work.append((asm, enumerate_operations(asm, "online")))
    n = sum(len(ops) for _, ops in work)
    desc, render = [], []
    for _ in range(a.repeats):
        t = time.perf_counter()
        for asm, ops in work:
            descriptors_for(DescriptorContext(asm), ops)
        desc.append(time.perf_counter() - t)
        t = time.perf_counter()
        for asm, ops in work:
            for op in ops:
                render_pair(asm, op)
        render.append(time.perf_counter() - t)
    d, r = min(desc) / n * 1e3, min(render) / n * 1e3
    print(f"{n} operations of {len(NAMES)} assemblies, best of {a.repeats}")
    print(f"descriptors (NDBG included): {d:.3f} ms/operation")
    print(f"render_pair:                 {r:.3f} ms/operation")
    print(f"descriptors / images: {d / r:.2f}")


if __name__ == "__main__":
    main()

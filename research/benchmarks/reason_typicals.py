"""The typical values behind the step reasons' rule (``rap.plan.report.reasons.TYPICAL``).

    python -m research.benchmarks.reason_typicals

For every online operation of the six reference assemblies: the margin of its direction to the
nearer end of its range (degrees; single directions and the whole circle left out), the clearance
``depth * tan(margin)`` and the depth as fractions of the moving subassembly's extent (where the
depth is positive), and the sliding contact as a fraction of the moving perimeter (where
positive). Prints the medians and the quartiles.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import rap
from rap.enumerate import enumerate_operations
from rap.io import load_assembly
from rap.model.data.descriptors import DESCRIPTORS, DescriptorContext

NAMES = ("hexagon", "mixed-square", "pentagons", "rectilinear", "grid", "triangles")


def main() -> None:
    data = Path(rap.__file__).resolve().parent / "data" / "assemblies"
    got = {"margin_deg": [], "clearance": [], "depth": [], "sliding": []}
    n = 0
    for name in NAMES:
        asm = load_assembly(data / f"{name}.json")
        ctx = DescriptorContext(asm)
        for op in enumerate_operations(asm, "online"):
            d = dict(zip(DESCRIPTORS, map(float, ctx.descriptors(op))))
            n += 1
            single, width, margin = d["single_direction"], d["range_width_rad"], d["margin_rad"]
            if not single and width < 2 * math.pi:
                got["margin_deg"].append(math.degrees(margin))
                if d["depth"] > 0 and margin < math.pi / 2:
                    got["clearance"].append(d["depth"] * math.tan(margin))
            if d["depth"] > 0:
                got["depth"].append(d["depth"])
            if d["sliding_contact"] > 0:
                got["sliding"].append(d["sliding_contact"])
    print(f"{n} online operations of {len(NAMES)} reference assemblies")
    for k, v in got.items():
        q = np.percentile(v, [25, 50, 75]) if v else [float("nan")] * 3
        print(f"{k:12s} n={len(v):5d}  median {q[1]:.3g}  (quartiles {q[0]:.3g}, {q[2]:.3g})")


if __name__ == "__main__":
    main()

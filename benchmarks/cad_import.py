"""Benchmark of ``rap-farm import``: a 100-part DXF drawing to a validated exact assembly.

Writes (with ezdxf) a 10 x 10 grid of 10 mm cells, each a closed LWPOLYLINE on a layer of its
own, every interior edge a bulge (an arc drawn from both sides, with opposite bulges), and prints
the median wall time of ``rap.cad.import_drawing`` over ``--repeat`` runs, with the share of the
validation (``rap.assembly`` + ``rap.geometry.validation``, as ``rap.io.parse_assembly``) and the
counts (parts, vertices). The target of issue 29 is under 2 s.

    python benchmarks/cad_import.py [--cells 10] [--repeat 5] [--tolerance 0.01]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.cad import ImportOptions, import_drawing  # noqa: E402


def write_grid(path: Path, n: int = 10, size: float = 10.0, bulge: float = 0.2) -> Path:
    """An n x n grid of cells, each its own closed LWPOLYLINE on layer ``cI_J``; every interior
    vertical edge bulges towards +x and every interior horizontal edge towards +y, drawn from
    both sides (a positive bulge bulges to the right of the direction of travel)."""
    import ezdxf

    doc = ezdxf.new("R2010", units=4)  # millimetres
    msp = doc.modelspace()
    for i in range(n):
        for j in range(n):
            x0, y0, x1, y1 = i * size, j * size, (i + 1) * size, (j + 1) * size
            bottom = -bulge if j > 0 else 0  # left to right: +y is to the left
            right = bulge if i < n - 1 else 0  # upwards: +x is to the right
            top = bulge if j < n - 1 else 0  # right to left: +y is to the right
            left = -bulge if i > 0 else 0  # downwards: +x is to the left
            msp.add_lwpolyline([(x0, y0, bottom), (x1, y0, right), (x1, y1, top),
                                (x0, y1, left)], format="xyb", close=True,
                               dxfattribs={"layer": f"c{i}_{j}"})
    doc.saveas(path)
    return Path(path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, default=10, help="cells per side (parts = cells^2)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--tolerance", default="0.01")
    args = ap.parse_args()
    from rap.geometry import validation  # import_drawing looks validate_assembly up per call

    with tempfile.TemporaryDirectory() as tmp:
        path = write_grid(Path(tmp) / "grid.dxf", args.cells)
        options = ImportOptions(tolerance=args.tolerance)
        import_drawing(path, options)  # imports ezdxf, warms caches
        spent = {"validation": 0.0}
        validate = validation.validate_assembly

        def timed_validate(assembly):
            t0 = time.perf_counter()
            validate(assembly)
            spent["validation"] += time.perf_counter() - t0

        validation.validate_assembly = timed_validate
        walls, checks = [], []
        try:
            for _ in range(args.repeat):
                spent["validation"] = 0.0
                t0 = time.perf_counter()
                result = import_drawing(path, options)
                walls.append(time.perf_counter() - t0)
                checks.append(spent["validation"])
        finally:
            validation.validate_assembly = validate
    print(f"drawing: {args.cells}x{args.cells} cells, {len(result.assembly)} parts, "
          f"{result.vertices} vertices after import ({result.summary()})")
    print(f"import_drawing: median {statistics.median(walls):.3f} s over {args.repeat} runs "
          f"(min {min(walls):.3f} s, max {max(walls):.3f} s); of which geometric validation "
          f"median {statistics.median(checks):.3f} s")


if __name__ == "__main__":
    main()

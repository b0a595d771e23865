"""Import every drawing of a folder (default ``../shared/drawings``) as a new user would: the
defaults first, then the one flag the refusal names; print a markdown table (outcome, parts, area,
vertices, flags, seconds per import) for docs/ASSEMBLIES.md.

    python benchmarks/drawings.py [FOLDER]

Each import runs in this process after a warm-up import (library loading is not counted); the
time is the median of three imports.
"""

from __future__ import annotations

import re
import statistics
import sys
import time
from pathlib import Path

from rap.cad import DrawingError, ImportOptions, import_drawing

#: the one flag a refusal may name, as ImportOptions fields
_FLAGS = (
    (re.compile(r"\(--layers (\S+) --tolerance (\S+) absorbs"),
     lambda m: {"layers": (m.group(1),), "tolerance": m.group(2)}),
    (re.compile(r"--tolerance (\S+) absorbs"), lambda m: {"tolerance": m.group(1)}),
    (re.compile(r"--tolerance (\S+) closes"), lambda m: {"tolerance": m.group(1)}),
    (re.compile(r"--parts face reads"), lambda m: {"parts": "face"}),
)


def _timed(path: Path, options: ImportOptions):
    times, result = [], None
    for _ in range(3):
        t0 = time.perf_counter()
        result = import_drawing(path, options)
        times.append(time.perf_counter() - t0)
    return result, statistics.median(times)


def _row(path: Path) -> str:
    try:
        result, seconds = _timed(path, ImportOptions())
        flags = "none"
    except DrawingError as exc:
        for pattern, make in _FLAGS:
            m = pattern.search(str(exc))
            if m:
                options = make(m)
                try:
                    result, seconds = _timed(path, ImportOptions(**options))
                except DrawingError as again:
                    return f"| {path.name} | refused twice | | | | {again.problem[:120]} | |"
                flags = " ".join(f"--{k} {','.join(v) if isinstance(v, tuple) else v}"
                                 for k, v in options.items())
                break
        else:
            return f"| {path.name} | refused | | | | {exc.problem[:160]} | |"
    a = result.assembly
    area = sum(float(p.area()) for p in a.parts)
    return (f"| {path.name} | imported ({result.made_by}) | {len(a)} | {area:.1f} | "
            f"{result.vertices} | {flags} | {seconds:.2f} |")


def main(folder: str = "../shared/drawings") -> None:
    files = sorted(p for p in Path(folder).iterdir() if p.suffix.lower() in (".dxf", ".svg"))
    for path in files[:1]:  # warm-up: the imports of ezdxf, svgelements and shapely
        _row(path)
    print("| drawing | outcome | parts | area (mm^2) | vertices | flags | s |")
    print("|---|---|---:|---:|---:|---|---:|")
    for path in files:
        print(_row(path), flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])

"""Import every drawing of a folder (default ``../shared/drawings``) as a new user would: the
defaults first, then the one flag the refusal names; print a markdown table (outcome, parts, area,
vertices, flags, seconds per import) for docs/ASSEMBLIES.md.

    python benchmarks/drawings.py [FOLDER] [--plan]

Each import runs in this process after a warm-up import (library loading is not counted); the
time is the median of three imports. ``--plan`` then plans every drawing that imported, cold: a
fresh ``python -m rap.cli plan`` process with an empty score cache, on the drawing itself (or, when
it needs a flag, on the assembly imported with it), and prints a second table: exit status, R or
the interlocked pieces, and the seconds from the start of the process (import included).
"""

from __future__ import annotations

import json
import re
import statistics
import sys
import tempfile
import time
from pathlib import Path

from rap.assembly import assembly_to_json
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


def _imported(path: Path):
    """(result, seconds, flags text, options) of the defaults or the one flag the refusal names;
    (None, 0, what was refused, None) when it is refused."""
    try:
        result, seconds = _timed(path, ImportOptions())
        return result, seconds, "none", {}
    except DrawingError as exc:
        for pattern, make in _FLAGS:
            m = pattern.search(str(exc))
            if m:
                options = make(m)
                try:
                    result, seconds = _timed(path, ImportOptions(**options))
                except DrawingError as again:
                    return None, 0.0, f"refused twice: {again.problem[:120]}", None
                flags = " ".join(f"--{k} {','.join(v) if isinstance(v, tuple) else v}"
                                 for k, v in options.items())
                return result, seconds, flags, options
        return None, 0.0, f"refused: {exc.problem[:160]}", None


def _row(path: Path, result, seconds: float, flags: str) -> str:
    if result is None:
        outcome, _, why = flags.partition(": ")
        return f"| {path.name} | {outcome} | | | | {why} | |"
    a = result.assembly
    area = sum(float(p.area()) for p in a.parts)
    return (f"| {path.name} | imported ({result.made_by}) | {len(a)} | {area:.1f} | "
            f"{result.vertices} | {flags} | {seconds:.2f} |")


def _plan_row(path: Path, result, options: dict) -> str:
    """A cold ``plan`` of the drawing (or of its import with the flag), as a table row."""
    from curved_parts import cold_plan  # benchmarks/, this script's folder

    with tempfile.TemporaryDirectory() as tmp:
        target = path
        if options:
            target = Path(tmp) / f"{path.stem}.json"
            target.write_text(json.dumps(assembly_to_json(result.assembly)))
        wall, status, doc = cold_plan(target)
    if status == 0:
        what = f"R {doc['robustness']:.3f}"
    else:
        lines = doc["stderr"].strip().splitlines()
        what = lines[-1][:140] if lines else ""
    return f"| {path.name} | {status} | {what} | {wall:.1f} |"


def main(*argv: str) -> None:
    want_plan = "--plan" in argv
    folders = [a for a in argv if a != "--plan"]
    folder = folders[0] if folders else "../shared/drawings"
    files = sorted(p for p in Path(folder).iterdir() if p.suffix.lower() in (".dxf", ".svg"))
    for path in files[:1]:  # warm-up: the imports of ezdxf, svgelements and shapely
        _imported(path)
    print("| drawing | outcome | parts | area (mm^2) | vertices | flags | s |")
    print("|---|---|---:|---:|---:|---|---:|")
    imported = []
    for path in files:
        result, seconds, flags, options = _imported(path)
        print(_row(path, result, seconds, flags), flush=True)
        if result is not None:
            imported.append((path, result, options))
    if want_plan:
        print("\n| drawing | plan exit | R or why not | s (cold) |")
        print("|---|---:|---|---:|")
        for path, result, options in imported:
            print(_plan_row(path, result, options), flush=True)


if __name__ == "__main__":
    main(*sys.argv[1:])

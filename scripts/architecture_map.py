"""Maintainer tool: write the package map of docs/ARCHITECTURE.md from the modules' docstrings.

    python scripts/architecture_map.py      # rewrites the map's code block in place

Each module and package of ``rap/`` gets one entry, indented by its depth, with the first
paragraph of its docstring (at most two lines). ``tests/test_architecture.py`` checks that the map
names every module and nothing else; run this after adding, moving or removing one.
"""

from __future__ import annotations

import ast
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "ARCHITECTURE.md"
COLUMN, WIDTH = 24, 100


def summary(path: Path) -> str:
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    return " ".join(doc.strip().split("\n\n")[0].split())


def entries(folder: Path, indent: int) -> list[str]:
    lines: list[str] = []

    def emit(name: str, text: str) -> None:
        wrapped = textwrap.wrap(text, WIDTH - COLUMN)
        if len(wrapped) > 2:
            wrapped = [wrapped[0], wrapped[1].rstrip(".,;:") + " ..."]
        head = " " * indent + name
        if not wrapped:
            lines.append(head)
            return
        if len(head) >= COLUMN - 1:
            lines.append(head)
        else:
            lines.append(head.ljust(COLUMN) + wrapped.pop(0))
        lines.extend(" " * COLUMN + w for w in wrapped)

    items = sorted(folder.iterdir(), key=lambda p: (p.is_dir(), p.name))
    for p in items:
        if p.is_file() and p.suffix == ".py" and p.name != "__init__.py":
            emit(p.name, summary(p))
    for p in items:
        if p.is_dir() and (p / "__init__.py").exists():
            emit(p.name + "/", summary(p / "__init__.py"))
            lines += entries(p, indent + 2)
    return lines


def main() -> None:
    text = DOC.read_text(encoding="utf-8")
    head, rest = text.split("\n```\nrap/\n", 1)
    _, tail = rest.split("\n```", 1)
    block = "\n".join(entries(ROOT / "rap", 2))
    DOC.write_text(f"{head}\n```\nrap/\n{block}\n```{tail}", encoding="utf-8")
    print(f"wrote the map of {block.count(chr(10)) + 1} lines into {DOC}")


if __name__ == "__main__":
    main()

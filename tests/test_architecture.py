"""docs/ARCHITECTURE.md's map of the package names every module of ``rap/`` and nothing else, and
no folder of ``rap/`` outgrows a room (at most 12 modules, one module a command in commands/)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RAP = ROOT / "rap"
ENTRY = re.compile(r"^( *)([A-Za-z_][\w]*(?:\.py|/))(?: |$)")


def mapped() -> set[str]:
    """The paths the map's code block names, from its indentation (two spaces a level)."""
    text = (ROOT / "docs" / "ARCHITECTURE.md").read_text(encoding="utf-8")
    block = text.split("\n```\nrap/\n", 1)[1].split("\n```", 1)[0]
    stack: list[str] = []
    out = set()
    for line in block.splitlines():
        m = ENTRY.match(line)
        if m is None or len(m.group(1)) >= 20:  # a description's continuation line
            continue
        depth = len(m.group(1)) // 2 - 1
        stack = stack[:depth] + [m.group(2)]
        out.add("".join(stack))
    return out


def actual() -> set[str]:
    out = set()
    for p in RAP.rglob("*.py"):
        rel = p.relative_to(RAP)
        if "__pycache__" in rel.parts:
            continue
        out.add(str(rel.parent) + "/" if p.name == "__init__.py" else str(rel))
    out.discard("./")
    return out


def test_the_map_names_every_module_and_nothing_else():
    have, drawn = actual(), mapped()
    assert not have - drawn, f"modules missing from docs/ARCHITECTURE.md: {sorted(have - drawn)}"
    assert not drawn - have, f"the map names what does not exist: {sorted(drawn - have)}"


def test_no_folder_holds_more_than_a_dozen_modules_and_no_module_400_lines():
    big = {str(d.relative_to(ROOT)): n for d in [RAP, *RAP.rglob("*")] if d.is_dir()
           and d.name != "commands"
           and (n := len([p for p in d.glob("*.py") if p.name != "__init__.py"])) > 12}
    assert not big, big
    long = {str(p.relative_to(ROOT)): n for p in RAP.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 400}
    assert not long, long

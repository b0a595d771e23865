"""The package's import graph: layers import downward only, no cycles, ray only in the orchestration
layer (rap.farm, rap.serve).

Every ``import`` of a ``rap`` module counts, including those inside functions (a lazy import is
still a dependency). The graph is read from the source with ``ast``; nothing is imported.
"""

from __future__ import annotations

import ast
from pathlib import Path

import networkx as nx

RAP = Path(__file__).resolve().parents[1] / "rap"

# lower number = lower layer; a module may import modules of its own layer or below
LAYERS = {
    "rap.errors": 0, "rap.config": 0, "rap.seeds": 0, "rap.stats": 0,
    "rap.assembly": 1, "rap.assembly_reader": 1, "rap.operation": 1,
    "rap.geometry": 2, "rap.io": 3, "rap.enumerate": 3,
    "rap.sim": 4, "rap.render": 4, "rap.dataset": 4,
    "rap.model": 5, "rap.labelling": 5, "rap.execution": 5, "rap.plan": 6, "rap.experiment": 7, "rap.robot": 7,
    "rap.farm": 8, "rap.serve": 9, "rap.commands": 10, "rap.cli": 11,
    "rap.files": 0, "rap.client": 10, "rap.cad": 3,
}


def module_name(path: Path) -> str:
    rel = path.relative_to(RAP.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def layer(mod: str) -> int | None:
    best = None
    for prefix, lv in LAYERS.items():
        if mod == prefix or mod.startswith(prefix + "."):
            if best is None or len(prefix) > len(best[0]):
                best = (prefix, lv)
    return None if best is None else best[1]


def imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
            out |= {f"{node.module}.{a.name}" for a in node.names}
    return out


def graph() -> nx.DiGraph:
    mods = {module_name(p): p for p in RAP.rglob("*.py")}
    g = nx.DiGraph()
    for mod, path in mods.items():
        g.add_node(mod)
        for target in imports(path):
            if target in mods and target != mod:
                g.add_edge(mod, target)
            elif target.split(".")[0] == "ray":
                g.add_edge(mod, "ray")
    return g


def test_no_import_cycles():
    cycles = list(nx.simple_cycles(graph()))
    assert not cycles, cycles


def test_layers_import_downward_only():
    bad = []
    for a, b in graph().edges:
        la, lb = layer(a), layer(b)
        if la is not None and lb is not None and lb > la:
            bad.append(f"{a} -> {b}")
    assert not bad, bad


# the orchestration layer: the labelling farm and the planning service that runs on its pool
ORCHESTRATION = ("rap.farm", "rap.serve")
# modules of the orchestration packages that must stay free of ray (imported by tests and the CLI
# without starting anything)
RAY_FREE = ("rap.serve.api", "rap.serve.examples", "rap.serve.robot_program")


def test_only_the_orchestration_layer_imports_ray():
    users = {a for a, b in graph().edges if b == "ray"}
    assert users and all(u.startswith(ORCHESTRATION) for u in users), users
    g = graph()
    assert not [m for m in RAY_FREE if "ray" in nx.descendants(g, m)], RAY_FREE


def test_the_package_never_imports_the_research_or_its_tests():
    """research/ (experiments), scripts/, benchmarks/ and tests/ sit beside the package: nothing in
    rap imports them."""
    outside = ("research", "scripts", "benchmarks", "tests")
    bad = sorted(f"{module_name(p)} -> {t}" for p in RAP.rglob("*.py") for t in imports(p)
                 if t.split(".")[0] in outside)
    assert not bad, bad


def private_imports(path: Path) -> list[tuple[str, str]]:
    """``(module, name)`` of every ``from rap... import _name`` in ``path`` (``__version__`` is
    public)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [(node.module, a.name) for node in ast.walk(tree)
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0
            and node.module.split(".")[0] == "rap"
            for a in node.names if a.name.startswith("_") and a.name != "__version__"]


def test_no_module_imports_another_modules_private_names():
    """A leading underscore means "this module only": nothing in rap, research/, scripts/,
    benchmarks/ or jobs/ imports such a name from another module. A test may reach into the one
    module it mirrors (tests/geometry/test_partitions.py -> rap.geometry.partitions)."""
    root = RAP.parent
    bad = []
    for folder in ("rap", "research", "scripts", "benchmarks", "jobs", "tests"):
        for path in (root / folder).rglob("*.py"):
            for module, name in private_imports(path):
                rel = path.relative_to(root)
                mirrored = (rel.parts[0] == "tests" and rel.name.startswith("test_")
                            and module.split(".")[1:] == [*rel.parts[1:-1], rel.stem[5:]])
                if not mirrored:
                    bad.append(f"{rel}: from {module} import {name}")
    assert not bad, bad


def test_the_private_names_check_sees_a_private_import(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("from rap.plan.search.planner import _helper, public\nfrom rap import __version__\n")
    assert private_imports(src) == [("rap.plan.search.planner", "_helper")]

"""examples/: the drawings import as the parts they draw and come apart; the DXF is what its
script writes; the Python example plans through the front door; CITATION.cff reads.

The tutorial's commands (import, plan, the cell's flags) run in tests/test_tutorial.py; here
nothing is simulated except by the Python example (one plan, a few seconds).
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

from rap.cad.importer import ImportOptions, import_drawing

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"

#: (drawing, its parts)
DRAWINGS = [
    ("bracket.dxf", {"plate", "bracket", "peg", "spacer"}),
    ("clip.svg", {"base", "post-left", "post-right", "knob", "lid"}),
]


@pytest.mark.parametrize("name,parts", DRAWINGS, ids=[d[0] for d in DRAWINGS])
def test_a_drawing_imports_in_millimetres_with_its_arcs(name, parts):
    for tolerance in ("0.01", "0.1"):  # the default, and the tutorial's
        assembly = import_drawing(EXAMPLES / name, ImportOptions(tolerance=tolerance)).assembly
        assert {p.id for p in assembly.parts} == parts
        assert assembly.units == "mm"
        # arcs flattened: the round ends and fillets give the curved parts many vertices
        assert max(len(p.outer) for p in assembly.parts) > 20


@pytest.mark.parametrize("name", [d[0] for d in DRAWINGS])
def test_inspect_finds_no_interlocked_subassembly(run_cli, name):
    code, out, err = run_cli("inspect", EXAMPLES / name)
    assert code == 0, err
    assert "interlocked subassemblies: none found" in out


def test_the_layered_drawing_imports_its_parts_and_leaves_the_annotations_out():
    result = import_drawing(EXAMPLES / "layered.svg")
    assert {p.id for p in result.assembly.parts} == {"channel", "slider", "cap"}
    assert sum(float(p.area()) for p in result.assembly.parts) == 60 * 40 - 40 * 30 + 39 * 25 \
        + 60 * 8
    line = result.summary()
    for what in ("open paths on layer 'Dimensions'", "1 dashed line on layer 'Dimensions'",
                 "1 frame on layer 'Sheet'", "1 text on layer 'Dimensions'"):
        assert what in line, line
    chosen = import_drawing(EXAMPLES / "layered.svg", ImportOptions(layers=("Parts",)))
    assert chosen.assembly.geometry_hash == result.assembly.geometry_hash


def test_the_dxf_is_what_its_script_writes(tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location("make_bracket_dxf",
                                                  EXAMPLES / "make_bracket_dxf.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "OUT", tmp_path / "bracket.dxf")
    module.main()
    fresh = import_drawing(tmp_path / "bracket.dxf").assembly
    committed = import_drawing(EXAMPLES / "bracket.dxf").assembly
    assert fresh.geometry_hash == committed.geometry_hash


def test_citation_names_the_paper_and_the_tool():
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    paper = cff["preferred-citation"]
    assert paper["title"].startswith("Robust 2D Assembly Sequencing")
    assert [a["family-names"] for a in paper["authors"]] == ["Geft", "Tamar", "Goldberg",
                                                             "Halperin"]
    from rap import __version__

    assert cff["version"] == __version__


@pytest.mark.slow
def test_the_python_example_plans_through_the_front_door(tmp_path):
    import rap.plan

    if not hasattr(rap.plan, "plan"):
        pytest.skip("rap.plan.plan (the front door, issue 36 item 2) is not in this build yet")
    out = tmp_path / "plan.json"
    p = subprocess.run([sys.executable, str(EXAMPLES / "plan_in_python.py"), "--out", str(out)],
                       cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "bracket: 3 steps" in p.stdout and out.is_file()

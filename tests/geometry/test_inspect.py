"""``rap-farm inspect``: the exact JSON document and the human summary."""

from __future__ import annotations

import json

from rap.assembly import assembly_to_json

from .fixtures import FRAMED_LOOSE, GRID2


def _write(tmp_path, asm):
    p = tmp_path / f"{asm.name}.json"
    p.write_text(json.dumps(assembly_to_json(asm)))
    return p


def test_json_document(tmp_path, run_cli):
    code, out, err = run_cli("inspect", _write(tmp_path, GRID2), "--json")
    assert code == 0 and err == ""
    doc = json.loads(out)
    assert list(doc) == ["assembly", "parts", "cells"]
    assert doc["assembly"] == "grid2" and doc["parts"] == ["r0c0", "r0c1", "r1c0", "r1c1"]
    assert len(doc["cells"]) == 8
    first = doc["cells"][0]
    assert set(first) == {"kind", "direction", "blocks"}
    assert first["kind"] == "vertex" and first["direction"] == [1.0, 0.0]
    assert first["blocks"] == [["r0c0", "r0c1"], ["r1c0", "r1c1"]]
    for c in doc["cells"]:
        assert c["blocks"] == sorted(c["blocks"])


def test_human_summary(tmp_path, run_cli):
    code, out, _ = run_cli("inspect", _write(tmp_path, FRAMED_LOOSE))
    assert code == 0
    assert "frame" in out and "Counts" in out
    assert "interlocked subassemblies: {core,frame}" in out

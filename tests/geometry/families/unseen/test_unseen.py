"""Held-out shape kinds (rap.geometry.families.unseen): valid, integer, not interlocked, 6-12
parts with the default options, seeded, selectable by name, never a training family."""

from __future__ import annotations

import pytest

from rap.geometry.andor import decomposition
from rap.geometry.families import ALL_FAMILIES, FAMILIES, HELD_OUT, generate
from rap.geometry.families.unseen import UNSEEN
from rap.geometry.ndbg import build_ndbg
from rap.geometry.validation import validate_assembly

NAMES = sorted(UNSEEN)
CASES = [(name, seed) for name in NAMES for seed in range(4)]


def test_registry_keeps_them_out_of_training():
    assert set(NAMES) == {"arch", "dovetail", "puzzle", "bond"} == HELD_OUT
    assert not HELD_OUT & set(FAMILIES)
    assert all(ALL_FAMILIES[n] is UNSEEN[n] and not UNSEEN[n].training for n in NAMES)
    assert all(f.training for f in FAMILIES.values())


@pytest.mark.parametrize("name,seed", CASES)
def test_valid_integer_not_interlocked_sized(name, seed):
    asm = generate(name, seed)
    assert asm.name == f"{name}-s{seed}" and asm.family == name
    assert 6 <= len(asm) <= 12
    validate_assembly(asm)
    for p in asm.parts:
        for ring in p.rings():
            assert all(x.denominator == 1 and y.denominator == 1 for x, y in ring)
    tree = decomposition(build_ndbg(asm))
    assert tree is not None and len(tree) == len(asm) - 1


@pytest.mark.parametrize("name", NAMES)
def test_seeded(name):
    a, b, c = generate(name, 7), generate(name, 7), generate(name, 8)
    assert a.parts == b.parts
    assert a.parts != c.parts


@pytest.mark.parametrize("name,options,parts", [
    ("arch", {"pairs": 3, "kind": "arch"}, 10), ("arch", {"pairs": 2, "kind": "vault"}, 10),
    ("dovetail", {"blocks": 4}, 8), ("puzzle", {"rows": 3, "cols": 4}, 12),
    ("bond", {"bond": "english", "courses": 3}, 10), ("bond", {"bond": "flemish", "courses": 2}, 8)])
def test_options_set_the_part_count(name, options, parts):
    assert len(generate(name, 1, **options)) == parts


def test_arch_has_a_keystone_and_curved_tabs_are_polylines():
    arch = generate("arch", 0, pairs=3, kind="arch")
    assert {"key", "pierL", "pierR", "base"} <= {p.id for p in arch.parts}
    puzzle = generate("puzzle", 0)
    assert max(len(p.outer) for p in puzzle.parts) > 20  # tabs sampled at every integer step


def test_rap_farm_generate_makes_them_and_lists_them_as_held_out(tmp_path):
    from typer.testing import CliRunner

    from rap.cli import app
    from rap.io import load_assembly

    out = tmp_path / "arch.json"
    res = CliRunner().invoke(app, ["generate", "arch", "--seed", "0", "--pairs", "3", "--kind",
                                   "arch", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert len(load_assembly(out)) == 10
    listed = CliRunner().invoke(app, ["generate", "list"], env={"COLUMNS": "250"})
    assert listed.exit_code == 0 and "held out" in listed.output and "dovetail" in listed.output

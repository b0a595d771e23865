"""Assembly families: valid, not interlocked, integer, seeded, part counts as the options say; CLI."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rap.assembly import Assembly
from rap.io import load_assembly
from rap.errors import InputError, ParameterError
from rap.geometry.andor import decomposition
from rap.geometry.families import DEFAULT_PARTS, FAMILIES, assembly_name, family_table, generate, family_rng
from rap.geometry.families.base import make_part, shared_edge, socket_profile
from rap.geometry.families.packings import union_ring
from rap.geometry.ndbg import build_ndbg
from rap.geometry.partitions import online_partitions
from rap.geometry.validation import validate_assembly

NAMES = sorted(FAMILIES)
SEEDS = (0, 1, 2)
CASES = [(name, seed) for name in NAMES for seed in SEEDS]


@pytest.fixture(scope="module")
def generated():
    """(family, seed) -> assembly, generated once per module."""
    return {(name, seed): generate(name, seed) for name, seed in CASES}


def test_registry():
    assert len(FAMILIES) >= 10
    for name, fam in FAMILIES.items():
        assert fam.name == name and fam.description and "\n" not in fam.description
        assert len({o.name for o in fam.options}) == len(fam.options)
        lo, hi = fam.part_range()
        assert DEFAULT_PARTS[0] <= lo <= hi <= DEFAULT_PARTS[1], name
    assert [row[0] for row in family_table()] == list(FAMILIES)


def test_geometry_layer_only():
    import subprocess
    import sys

    code = ("import sys; from rap.geometry.families import generate; generate('hub', 0); "
            "print(sorted(m for m in ('ray', 'torch', 'pymunk', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("name,seed", CASES)
def test_valid_integer_not_interlocked(generated, name, seed):
    asm = generated[name, seed]
    assert asm.name == f"{name}-s{seed}"
    validate_assembly(asm)
    for p in asm.parts:
        assert 1 <= len(p.id) <= 6 and "," not in p.id
        for ring in p.rings():
            assert all(x.denominator == 1 and y.denominator == 1 for x, y in ring)
    x0, y0, x1, y1 = asm.bounds()
    assert max(x1 - x0, y1 - y0) <= 300
    tree = decomposition(build_ndbg(asm))
    assert tree is not None and len(tree) == len(asm) - 1


@pytest.mark.parametrize("name,seed", CASES)
def test_part_count_follows_options(generated, name, seed):
    fam = FAMILIES[name]
    opts = fam.resolve(family_rng(name, seed))
    assert len(generated[name, seed]) == fam.count(opts)
    lo, hi = fam.part_range()
    assert lo <= len(generated[name, seed]) <= hi


@pytest.mark.parametrize("name", NAMES)
def test_deterministic_and_distinct(generated, name):
    again = generate(name, 1)
    assert again.parts == generated[name, 1].parts and again.family == name
    assert again.geometry_hash == generated[name, 1].geometry_hash
    hashes = {generated[name, s].geometry_hash for s in SEEDS} | {generate(name, 7).geometry_hash}
    assert len(hashes) == len(SEEDS) + 1


@pytest.mark.parametrize("name", NAMES)
def test_default_counts_stay_in_range(name):
    fam = FAMILIES[name]
    for seed in range(60):
        n = fam.count(fam.resolve(family_rng(name, seed)))
        assert DEFAULT_PARTS[0] <= n <= DEFAULT_PARTS[1]


@pytest.mark.parametrize("name,options,parts", [
    ("wall", {"rows": 4, "bricks": 5}, 22),
    ("convex", {"rows": 5, "cols": 6, "cell": "quad"}, 30),
    ("convex", {"rows": 3, "cols": 2, "cell": "tri"}, 12),
    ("convex", {"rows": 3, "cols": 3, "cell": "hex"}, 10),
    ("pegs", {"blocks": 3, "layers": 2}, 7),
    ("funnels", {"blocks": 2, "layers": 1, "shape": "v"}, 3),
    ("hub", {"sides": "6", "rings": 2}, 13),
    ("c-shapes", {"columns": 3, "kind": "c-side"}, 7),
    ("knobs", {"rows": 3, "cols": 3, "shape": "round"}, 9),
    ("packing", {"parts": 9, "ells": 2, "clearance": 0}, 9),
    ("polyomino", {"cols": 4, "rows": 4, "pieces": 5}, 5),
    ("fan", {"triangles": 6, "layout": "half"}, 7),
])
def test_explicit_options(name, options, parts):
    asm = generate(name, 3, **options)
    assert len(asm) == parts
    assert asm.name == assembly_name(name, 3, **options)
    assert asm.name.startswith(f"{name}-s3-")


@pytest.mark.parametrize("name", NAMES)
def test_option_extremes(name):
    """Every option at its lowest and highest value (the others drawn) builds a verified
    assembly (``generate`` verifies), or for a combination it rejects a one-line ParameterError
    naming one of the family's options, or a one-line InputError naming the family."""
    fam = FAMILIES[name]
    for o in fam.options:
        for v in (o.choices if o.choices else (o.low, o.high)):
            base = {p.name: p.default if p.default is not None else p.drawn[0] for p in fam.options}
            if fam.count({**base, o.name: v}) > 40:
                continue
            try:
                generate(name, 0, **{o.name: v})
            except ParameterError as exc:
                assert "\n" not in str(exc) and exc.parameter in {p.name for p in fam.options}
                assert str(exc).startswith(f"{exc.parameter} ")
            except InputError as exc:
                assert "\n" not in str(exc) and str(exc).startswith(f"{name}: ")


SHAPES = ", ".join(FAMILIES["knobs"].option("shape").choices)
BAD_VALUES = [  # (family, seed, options), the parameter named, the library's message
    (("wall", 0, {"rows": 0}), "rows", "rows 0: must be between 1 and 20"),
    (("knobs", 0, {"shape": "dovetail"}), "shape", f"shape 'dovetail': choose one of {SHAPES}"),
    (("wall", 0, {"rows": "4"}), "rows", "rows '4': must be an integer"),
    (("wall", 0, {"half": 6, "gap": 5}), "gap",
     "gap 5: must be at most half - 2 (4), so that half bricks keep a width"),
    (("fan", 0, {"layout": "pie", "triangles": 2}), "triangles",
     "triangles 2: a pie needs at least 3"),
    (("wall", -1, {}), "seed", "seed -1: must be a non-negative integer"),
]


@pytest.mark.parametrize("call, parameter, message", BAD_VALUES)
def test_bad_values_name_the_parameter(call, parameter, message):
    """The library speaks of its parameters (``generate``'s keywords), never of flags."""
    family, seed, options = call
    with pytest.raises(ParameterError) as err:
        generate(family, seed, **options)
    assert err.value.parameter == parameter and str(err.value) == message


def test_bad_options():
    with pytest.raises(InputError, match="no assembly family 'castle'"):
        generate("castle", 0)
    with pytest.raises(InputError, match="no option 'towers'"):
        generate("wall", 0, towers=2)


def test_large_instances():
    """Options allow instances beyond the corpus's 16 parts (convex ones rely on the theorem
    above ``CONVEX_THEOREM_PARTS``; the others are searched)."""
    assert len(generate("wall", 0, rows=8, bricks=10)) == 84
    assert len(generate("knobs", 0, rows=5, cols=6)) == 30


# -- building blocks ---------------------------------------------------------------------------
def test_union_ring():
    assert union_ring([(0, 0, 2, 1), (0, 1, 1, 3)]) == [(0, 0), (2, 0), (2, 1), (1, 1), (1, 3), (0, 3)]
    frame = [(0, 0, 3, 1), (0, 2, 3, 3), (0, 1, 1, 2), (2, 1, 3, 2)]
    assert union_ring(frame) is None  # a hole
    assert union_ring([(0, 0, 1, 1), (1, 1, 2, 2)]) is None  # a pinch


_profiles = st.lists(st.tuples(st.integers(0, 3), st.integers(1, 3)), min_size=1, max_size=3)


@settings(max_examples=40, deadline=None)
@given(base=st.integers(2, 6), steps=_profiles, clearance=st.integers(0, 3),
       side=st.sampled_from([1, -1]), slant=st.sampled_from([(1, 0), (1, 2), (-2, 1), (1, 1)]))
def test_knob_in_socket_separates_along_its_axis(base, steps, clearance, side, slant):
    """A non-increasing knob in its socket, on an edge of any integer direction: the two blocks
    are valid together and come apart along the edge normal (toward the socket's side)."""
    half, u, v = [(base, 0)], base, 0
    for du, dv in steps:
        u, v = max(0, u - du), v + dv
        half.append((u, v))
    if half[-1][0] == 0 and len(half) > 2 and half[-2][0] == 0:
        half.pop()
    ex, ey = slant
    g = 2 * (base + clearance) + 4
    a, b = (0, 0), (g * ex, g * ey)
    depth = (max(v for _, v in half) + clearance + 2) * side
    nx, ny = -ey * depth, ex * depth
    left_edge, right_edge = shared_edge(a, b, half, g // 2, side=side, clearance=clearance)
    left = make_part("left", [*left_edge, (b[0] + nx, b[1] + ny), (a[0] + nx, a[1] + ny)]
                     if side == 1 else [*left_edge, (b[0] - nx, b[1] - ny), (a[0] - nx, a[1] - ny)])
    far = -1 if side == 1 else 1
    right = make_part("right", [*right_edge, (a[0] + far * nx, a[1] + far * ny),
                                (b[0] + far * nx, b[1] + far * ny)])
    asm = Assembly("knob", (left, right))
    validate_assembly(asm)
    assert socket_profile(half, 0) == half
    ndbg = build_ndbg(asm)
    ps = online_partitions(ndbg, ndbg.ids)
    assert ps, "the knob must leave its socket"
    normal = (-ey, ex)  # the left part leaves along +normal
    assert any(p.contains(normal if p.moving == {"left"} else (-normal[0], -normal[1]))
               for p in ps)


# -- command line ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_cli_generates_every_family(tmp_path, run_cli, generated, name):
    out = tmp_path / f"{name}.json"
    code, stdout, err = run_cli("generate", name, "--seed", "2", "-o", out)
    assert code == 0, err
    asm = load_assembly(out)
    assert asm.name == f"{name}-s2" and asm.parts == generated[name, 2].parts
    assert f"({len(asm)} parts)" in stdout


@pytest.mark.parametrize("argv", [["wall", "--seed", "3"], ["grid", "--k", "3"],
                                  ["tiling", "--parts", "4"]])
def test_cli_output_is_out_like_every_other_command_and_output_still_works(tmp_path, run_cli,
                                                                            argv):
    written = []
    for flag in ("--out", "--output", "-o"):
        out = tmp_path / f"{flag.strip('-')}.json"
        code, _, err = run_cli("generate", *argv, flag, out)
        assert code == 0, err
        written.append(out.read_text())
    assert written[0] == written[1] == written[2]


def test_cli_options_and_list(tmp_path, run_cli):
    out = tmp_path / "wall.json"
    code, _, err = run_cli("generate", "wall", "--seed", "17", "--rows", "4", "--bricks", "5",
                           "--gap", "0", "-o", out)
    assert code == 0, err
    doc = json.loads(out.read_text())
    assert doc["name"] == "wall-s17-rows4-bricks5-gap0" and len(doc["parts"]) == 22
    code, stdout, _ = run_cli("generate", "list")
    assert code == 0
    for name in NAMES:
        assert name in stdout
    assert "--rows 1..20" in stdout


@pytest.mark.parametrize("args,message", [
    (["wall", "--rows", "0"], "wall: --rows 0: must be between 1 and 20"),
    (["wall", "--rows", "many"], "wall: --rows 'many': must be an integer"),
    (["knobs", "--shape", "dovetail"], f"knobs: --shape 'dovetail': choose one of {SHAPES}"),
    (["knobs", "--knob-pct", "1000"], "knobs: --knob-pct 1000: must be between "
     f"{FAMILIES['knobs'].option('knob_pct').low} and {FAMILIES['knobs'].option('knob_pct').high}"),
    (["fan", "--seed", "x"], "fan: --seed 'x': must be an integer"),
    (["fan", "--seed", "-1"], "fan: --seed -1: must be a non-negative integer"),
    (["wall", "--half", "4", "--gap", "3"],
     "wall: --gap 3: must be at most half - 2 (2), so that half bricks keep a width"),
])
def test_cli_bad_option(tmp_path, run_cli, args, message):
    """The command names the family and the flag where the library names the parameter."""
    out = tmp_path / "bad.json"
    code, _, err = run_cli("generate", *args, "-o", out)
    assert code == 2
    assert err == f"rap-farm: error: {message}\n"
    assert not out.exists()

"""The arm registry: one home for the arms, tied to the pybullet models, the cell and the formats;
UR's DH rows as the maker publishes them; a format the arm does not take is one line, exit 2."""

from __future__ import annotations

import math

import pytest

from rap.errors import EXIT_INPUT, InputError
from rap.robot.arm import ARM_MODELS
from rap.robot.arms.registry import ARMS, FORMATS, arm_spec, check_format, format_for_suffix
from rap.robot.cell import ARMS as CELL_ARMS
from rap.robot.cell import cell_from_toml

from tests.robot.cases import STACK, STACK_PLAN

# Universal Robots' table "DH parameters for calculations of kinematics and dynamics" (e-Series):
# d1, a2, a3, d4, d5, d6 in metres; alpha = (pi/2, 0, 0, pi/2, -pi/2, 0)
MAKER = {"ur5e": (0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996),
         "ur10e": (0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655)}


@pytest.mark.parametrize("name", sorted(MAKER))
def test_ur_dh_rows_are_the_makers_table(name):
    dh = ARMS[name].dh
    d1, a2, a3, d4, d5, d6 = MAKER[name]
    assert dh.d == (d1, 0.0, 0.0, d4, d5, d6) and dh.a == (0.0, a2, a3, 0.0, 0.0, 0.0)
    assert dh.alpha == (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)


def test_every_arm_is_complete_and_tied_to_the_cell_and_the_models():
    assert CELL_ARMS == tuple(ARMS) and set(ARM_MODELS) <= set(ARMS)
    for name, spec in ARMS.items():
        n = spec.dof
        assert len(spec.lower) == len(spec.upper) == len(spec.max_velocity) == len(spec.home) == n
        assert all(lo < h < hi for lo, h, hi in zip(spec.lower, spec.home, spec.upper))
        assert spec.formats and set(spec.formats) <= set(FORMATS)
        assert 0 < spec.repeatability_m <= 1e-4 and spec.reach_m > 0.5
        assert (spec.dh is None) == (spec.kinematics == "urdf") and spec.source
        if name in ARM_MODELS:  # the pybullet model uses the registry's figures
            m = ARM_MODELS[name]
            assert (m.lower, m.upper, m.home, m.joint_names) == (spec.lower, spec.upper,
                                                                   spec.home, spec.joint_names)
    panda = ARMS["panda"]
    assert len(panda.max_acceleration) == len(panda.max_jerk) == 7
    assert "urscript" not in panda.formats and ARMS["ur5e"].formats[0] == "urscript"


def test_the_cell_names_a_registry_arm():
    assert cell_from_toml('[robot]\narm = "ur10e"\n').robot.arm == "ur10e"
    with pytest.raises(InputError, match=r"robot\.arm: expected one of panda, ur5e, ur10e"):
        cell_from_toml('[robot]\narm = "ur5"\n')


@pytest.mark.parametrize("arm, fmt, words", [
    ("panda", "urscript", "format 'urscript': the panda (Franka Emika Panda) does not take it"),
    ("ur5e", "joint-trajectory-yaml", "format 'joint-trajectory-yaml': the ur5e"),
    ("ur5e", "pdf", "format 'pdf': unknown (choose one of urscript,"),
])
def test_a_format_the_arm_does_not_take_is_refused(arm, fmt, words):
    with pytest.raises(InputError) as err:
        check_format(arm, fmt)
    assert str(err.value).startswith(words) and "\n" not in str(err.value)
    assert err.value.exit_code == EXIT_INPUT
    with pytest.raises(InputError, match="^arm 'kuka': unknown"):
        arm_spec("kuka")


def test_suffixes_imply_formats():
    assert format_for_suffix("ur5e", ".script") == "urscript"
    assert format_for_suffix("panda", ".YAML") == "joint-trajectory-yaml"
    assert format_for_suffix("panda", ".csv") == "waypoints-csv"
    assert format_for_suffix("panda", ".txt") == "joint-trajectory-yaml"  # the arm's default


@pytest.mark.parametrize("args, words", [
    (["--format", "urscript"], "--format 'urscript': the panda (Franka Emika Panda) does not "
                               "take it; it takes joint-trajectory-yaml"),
    (["--arm", "ur5e", "--format", "joint-trajectory-json"], "--format 'joint-trajectory-json'"
                                                             ": the ur5e"),
    (["--arm", "ur3"], "--arm 'ur3': unknown (known: panda, ur5e, ur10e)"),
])
def test_the_cli_refuses_in_one_line_exit_2(args, words, tmp_path, run_cli):
    out = tmp_path / "p.script"
    code, _, err = run_cli("export", STACK_PLAN, "--assembly", STACK, *args, "-o", out)
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1
    assert not out.exists()

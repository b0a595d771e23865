"""The cell file: the shipped TOML is the shipped dataclass; a bad key is one line naming it."""

from __future__ import annotations

import pytest

from rap.errors import EXIT_INPUT
from rap.robot.cell import DEFAULT_CELL_FILE, Cell, CellError, cell_from_toml, load_cell

from tests.robot.cases import STACK, STACK_PLAN


def test_the_shipped_toml_is_the_default_cell():
    assert load_cell(DEFAULT_CELL_FILE).to_dict() == Cell().to_dict()


@pytest.mark.parametrize("text, key", [
    ("[motion]\ninsertion_speed_m_s = -1\n", "motion.insertion_speed_m_s"),
    ("[robot]\narm = \"ur5\"\n", "robot.arm"),
    ("[tray]\ncolour = 3\n", "tray.colour"),
    ("[gripper]\noutput = true\n", "gripper.output"),
    ("[assembly]\nposition_m = [1]\n", "assembly.position_m"),
    ("[spaceship]\nx = 1\n", "[spaceship]"),
])
def test_a_bad_key_is_named(tmp_path, text, key):
    path = tmp_path / "cell.toml"
    path.write_text(text)
    with pytest.raises(CellError) as err:
        load_cell(path)
    assert key in str(err.value) and "\n" not in str(err.value)
    assert err.value.exit_code == EXIT_INPUT


def test_given_keys_override_and_slots_are_kept(tmp_path):
    path = tmp_path / "cell.toml"
    path.write_text("[assembly]\nyaw_deg = 30\n[tray]\nslots = { block1 = [0.3, -0.3] }\n")
    cell = load_cell(path)
    assert cell.assembly.yaw_deg == 30.0 and cell.tray.slot_of("block1") == (0.3, -0.3)
    assert cell.motion == Cell().motion



def test_a_cells_text_reads_as_its_file_does(tmp_path):
    text = "[assembly]\nyaw_deg = 30\n[tray]\nslots = { block1 = [0.3, -0.3] }\n"
    path = tmp_path / "cell.toml"
    path.write_text(text)
    assert cell_from_toml(text).to_dict() == load_cell(path).to_dict()
    with pytest.raises(CellError, match=r"^cell: not a TOML file \("):
        cell_from_toml("[assembly\n")
    with pytest.raises(CellError, match=r"^mine: robot\.arm: "):
        cell_from_toml("[robot]\narm = \"ur5\"\n", "mine")

def test_the_cli_exits_2_naming_the_key(tmp_path, run_cli):
    path = tmp_path / "cell.toml"
    path.write_text("[table]\nheight_m = \"high\"\n")
    code, _, err = run_cli("export", STACK_PLAN, "--assembly", STACK, "--cell", path,
                           "-o", tmp_path / "p.script")
    assert code == 2 and "table.height_m" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "p.script").exists()

"""The robot cell's help (rap.plan.cell.help): one line per parameter of ``CellConstraints``,
shown by the CLI's flags and the service's schema (the page's tooltips: tests/serve/test_page.py)."""

from __future__ import annotations

from dataclasses import fields

import typer

from rap.cli import app
from rap.serve.api import PLAN_BODY_OPENAPI
from rap.plan.cell.help import CELL_HELP
from rap.plan.cell.constraints import CellConstraints


def test_every_parameter_has_one_line_and_every_place_shows_it():
    assert list(CELL_HELP) == [f.name for f in fields(CellConstraints)]
    assert all(text and "\n" not in text for text in CELL_HELP.values())
    commands = typer.main.get_command(app).commands
    for command in ("plan", "experiment"):
        shown = {p.name: p.help for p in commands[command].params}
        assert {key: shown[key] for key in CELL_HELP} == CELL_HELP, command
    schema = PLAN_BODY_OPENAPI["requestBody"]["content"]["application/json"]["schema"]
    props = schema["properties"]["constraints"]["properties"]
    assert {k: p["description"] for k, p in props.items()} == CELL_HELP

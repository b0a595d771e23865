"""Shared test fixtures (keep this small): run the ``rap-farm`` CLI in-process."""

from __future__ import annotations

from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"


@pytest.fixture
def run_cli(capsys):
    """``run_cli(*args) -> (exit_status, stdout, stderr)`` through ``rap.cli.main``."""
    from rap.cli import main

    def run(*args: str):
        try:
            main([str(a) for a in args])
            code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        captured = capsys.readouterr()
        return code, captured.out, captured.err

    return run

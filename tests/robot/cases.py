"""Named fixtures of the robot tests: small plans made by ``rap-farm plan`` (their commands in
tests/robot/data/README.md) and their assemblies."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).parent / "data"
STACK_PLAN = DATA / "stack.plan.json"
STACK = ROOT / "assemblies" / "cells" / "stack.json"
WALL_PLAN = DATA / "brick-wall-22.plan.json"
WALL = ROOT / "assemblies" / "cells" / "brick-wall-22.json"
TANGRAM_PLAN = DATA / "tangram.plan.json"
TANGRAM = ROOT / "assemblies" / "unseen" / "tangram.json"

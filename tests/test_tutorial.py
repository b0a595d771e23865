"""docs/TUTORIAL.md's commands run as written: every line of its ```bash blocks, in order, in a
temporary directory holding a copy of examples/ (the tutorial's paths are relative to the
repository root), with a score cache of its own (``RAP_CACHE``), so the user's is never touched.

``rap-farm serve`` blocks: it is not run, only required to be in the tutorial. The Python
example needs the front door ``rap.plan.plan``; until it is in the build that line is skipped
(tests/test_examples.py says so). About 30-60 s on 2 cores: the plans simulate.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = ROOT / "docs" / "TUTORIAL.md"
BLOCK = re.compile(r"^```bash\n(.*?)^```", re.M | re.S)


def commands(text: str) -> list[str]:
    """The commands of ``text``'s ```bash blocks, in order (a line ending in a backslash goes on
    with the next; blank lines and comments are dropped)."""
    out = []
    for block in BLOCK.findall(text):
        joined = re.sub(r"\s*\\\n\s*", " ", block)
        out += [line.strip() for line in joined.splitlines()
                if line.strip() and not line.strip().startswith("#")]
    return out


def test_commands_parse():
    text = "a\n```bash\nrap-farm x \\\n    --y 1\n# note\n\nls\n```\n```python\nno\n```\n"
    assert commands(text) == ["rap-farm x --y 1", "ls"]


def test_the_tutorial_names_what_it_teaches():
    text = TUTORIAL.read_text(encoding="utf-8")
    run = commands(text)
    assert "rap-farm serve" in run  # the page: mentioned and shown, not run here
    joined = " ".join(run)
    for what in ("rap-farm import examples/bracket.dxf", "rap-farm import examples/clip.svg",
                 "rap-farm plan", "--base", "--gravity", "--linear", "--layers", "--csv",
                 "examples/plan_in_python.py"):
        assert what in joined, what


@pytest.mark.slow
@pytest.mark.e2e  # not in the default run: python -m pytest -m e2e
def test_the_tutorials_commands_run(tmp_path):
    import rap.plan

    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["RAP_CACHE"] = str(tmp_path / "scores.json")
    ran = []
    for command in commands(TUTORIAL.read_text(encoding="utf-8")):
        if command.startswith("rap-farm serve"):
            continue
        if "plan_in_python.py" in command and not hasattr(rap.plan, "plan"):
            continue  # the front door is not in this build yet
        p = subprocess.run(command, shell=True, cwd=tmp_path, env=env, capture_output=True,
                           text=True, timeout=300)
        assert p.returncode == 0, f"{command}\n{p.stdout[-2000:]}\n{p.stderr[-2000:]}"
        ran.append(command)
    for name in ("bracket.png", "bracket.json", "plan.json", "plan.csv", "plan.png", "clip.json",
                 "clip-plan.json"):
        assert (tmp_path / name).is_file(), name
    assert len(ran) >= 9

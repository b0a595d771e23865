"""Usage errors of every command: the CLI stack's short usage message (or one line), exit status 2.

One case per command (and a few per option kind), run in-process through ``rap.cli.main`` with the
typer/click versions installed; ``test_usage_error_in_a_subprocess`` runs the console script itself.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from rap.cli import COMMAND_MODULES

ROOT = Path(__file__).resolve().parents[1]
HEXAGON = str(ROOT / "assemblies" / "hexagon.json")

#: (argv, a word the message must contain); every command appears at least once
CASES = [
    (["nosuch"], "nosuch"),
    (["inspect"], "Missing"),
    (["inspect", HEXAGON, "--bogus"], "--bogus"),
    (["show", HEXAGON], "Missing"),
    (["generate", "grid", "10", "-o", "g.json"], "--k"),
    (["generate", "tiling", "--parts", "many", "-o", "t.json"], "--parts"),
    (["generate", "nosuch"], "nosuch"),
    (["simulate"], "Missing"),
    (["simulate", HEXAGON, "--moving", "hub", "--direction"], "--direction"),
    (["label"], "Missing"),
    (["label", HEXAGON, "--workers", "0", "--out", "d"], "--workers"),
    (["check"], "Missing"),
    (["check", "d", "--quarantine", "yes"], "unexpected extra argument"),
    (["train"], "Missing"),
    (["score"], "Missing"),
    (["evaluate"], "Missing"),
    (["plan"], "Missing"),
    (["plan", "--methd", "x", "A.json"], "--methd"),
    (["plan", HEXAGON, "--trials", "0"], "--trials"),
    (["plan", HEXAGON, "--seed", "x"], "--seed"),
    (["experiment"], "Missing"),
    (["demo", "--bogus"], "--bogus"),
    (["serve", "--port", "http"], "--port"),
    (["serve", "extra"], "unexpected extra argument"),
    (["import", "drawing.dxf"], "Missing"),
    (["export", "plan.json"], "Missing"),
    (["export", "plan.json", "-o", "p.txt", "--format", "pdf"], "--format"),
    (["execute"], "Missing"),
    (["execute", "plan.json", "--trials", "0"], "--trials"),
]


def test_every_command_has_a_usage_error_case():
    import importlib

    covered = {argv[0] for argv, _ in CASES}
    # a module whose command name is not its own (``import``, a keyword) says so in COMMAND
    names = {getattr(importlib.import_module(f"rap.commands.{m}"), "COMMAND", m)
             for m in COMMAND_MODULES}
    assert names <= covered


@pytest.mark.parametrize("argv,needle", CASES, ids=[" ".join(a)[:40] for a, _ in CASES])
def test_usage_error_exits_2_with_the_short_usage_message(run_cli, argv, needle, tmp_path,
                                                          monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(*argv)
    assert code == 2, (out, err)
    assert "Traceback" not in err and "File \"" not in err, err
    assert needle in err, err
    assert len(err.strip().splitlines()) <= 6, err
    assert not any(tmp_path.iterdir()), "a usage error wrote a file"


def test_version_and_help_exit_0(run_cli):
    code, out, _ = run_cli("--version")
    assert code == 0 and out.startswith("rap-farm ")
    code, out, _ = run_cli("plan", "--help")
    assert code == 0 and "--server" in out


def test_the_top_level_help_lists_every_exit_status(run_cli):
    from rap import errors

    code, out, _ = run_cli("--help")
    assert code == 0
    listed = " ".join(out.split("Exit status:")[1].split("Options:")[0].split())
    assert listed == ("0 ok, 1 no feasible sequence, 2 invalid input, 3 work failed (labelling, "
                      "workers, disk full), 4 internal error, 130 interrupted.")
    assert sorted(v for k, v in vars(errors).items() if k.startswith("EXIT_")) == [0, 1, 2, 3, 4,
                                                                                   130]


def test_a_command_module_that_cannot_be_imported_is_reported_not_skipped():
    import typer

    from rap.cli import register_commands

    target = typer.Typer()
    broken = register_commands(target, ("inspect", "nosuch"))
    assert list(broken) == ["nosuch"] and type(broken["nosuch"]) is ModuleNotFoundError
    assert str(broken["nosuch"]) == "No module named 'rap.commands.nosuch'"
    assert [c.name for c in target.registered_commands] == ["inspect"]


def test_the_console_script_refuses_to_run_without_a_command_module(tmp_path):
    """Every invocation, --help included, is one line and exit 4: never a CLI that lacks `demo`."""
    code = ("import sys\nsys.modules['rap.commands.demo'] = None\n"
            "from rap.cli import main\nmain(sys.argv[1:])")
    env = {k: v for k, v in os.environ.items() if k != "RAP_DEBUG"}
    env["PYTHONPATH"] = str(ROOT)
    for argv in (["--help"], ["inspect", HEXAGON]):
        p = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True,
                           env=env, cwd=tmp_path, timeout=120)
        assert (p.returncode, p.stdout) == (4, ""), p.stderr
        assert p.stderr == ("rap-farm: internal error: command module rap.commands.demo cannot be "
                            "imported: ModuleNotFoundError: import of rap.commands.demo halted; None "
                            f"in sys.modules (a bug in rap-farm {__import__('rap').__version__}; "
                            "RAP_DEBUG=1 shows the traceback)\n")


@pytest.mark.parametrize("argv", [["plan"], ["inspect"], ["show", "-o", "a.png"],
                                  ["label", "--out", "ds"],
                                  ["simulate", "--moving", "a", "--direction", "1,0"]],
                         ids=lambda a: a[0])
def test_a_png_given_as_an_assembly_is_named_in_one_line(run_cli, argv, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "photo.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    code, out, err = run_cli(argv[0], "photo.png", *argv[1:])
    assert (code, out) == (2, "")
    assert err == ("rap-farm: error: photo.png: is a PNG image, not an assembly (JSON, DXF or "
                   "SVG)\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["photo.png"]


def test_usage_error_in_a_subprocess(tmp_path):
    """The console-script path (``python -m rap.cli``) with the installed CLI stack."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-m", "rap.cli", "plan", "--methd", "x", "A.json"],
                       capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    assert p.returncode == 2, p.stderr
    assert "No such option" in p.stderr and "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) <= 6


def test_a_local_plan_and_a_refused_serve_need_no_ray_torch_matplotlib_or_pyarrow(tmp_path):
    """The quick path: ``plan`` without --address plans in this process (the shipped model runs
    without torch); ``serve`` refuses a bad configuration before importing Ray."""
    blocked = ("ray", "torch", "matplotlib", "pyarrow", "pandas")
    code = (f"import sys\nfor m in {blocked!r}: sys.modules[m] = None\n"
            "from rap.cli import main\nmain(sys.argv[1:])")
    env = dict(os.environ, PYTHONPATH=str(ROOT), RAP_CACHE=str(tmp_path / "cache.json"))
    env.pop("RAY_ADDRESS", None)
    env.pop("RAP_FARM_TOKEN", None)
    p = subprocess.run([sys.executable, "-c", code, "plan", HEXAGON, "--trials", "4",
                        "--out", "p.json"], capture_output=True, text=True, env=env, cwd=tmp_path,
                       timeout=300)
    assert p.returncode == 0, p.stderr
    assert "robustness R" in p.stdout and (tmp_path / "p.json").is_file()
    assert "could not compare" not in p.stderr, p.stderr
    p = subprocess.run([sys.executable, "-c", code, "serve", "--host", "0.0.0.0"],
                       capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    assert p.returncode == 2 and "token" in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr


def test_an_internal_error_is_one_line_and_exit_4_never_1(run_cli, monkeypatch):
    """Exit 1 means "no feasible sequence": a bug must never look like that answer."""
    import rap.io

    def broken(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.delenv("RAP_DEBUG", raising=False)
    monkeypatch.setattr(rap.io, "load_assembly", broken)
    code, out, err = run_cli("inspect", HEXAGON)
    assert code == 4, err
    assert err.strip() == ("rap-farm: internal error: ZeroDivisionError: float division by zero "
                           f"(a bug in rap-farm {__import__('rap').__version__}; RAP_DEBUG=1 "
                           "shows the traceback)")


def test_a_file_that_cannot_be_written_is_one_line_and_exit_3(run_cli, tmp_path, monkeypatch):
    """An OSError (here ENOSPC from the picture writer) names the path; exit 3, no traceback."""
    import errno

    import rap.render.pictures as pictures

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "a.png"))

    monkeypatch.delenv("RAP_DEBUG", raising=False)
    monkeypatch.setattr(pictures, "assembly_figure", full)
    code, out, err = run_cli("show", HEXAGON, "-o", tmp_path / "a.png")
    assert code == 3, err
    assert err.strip() == (f"rap-farm: error: {tmp_path / 'a.png'}: No space left on device "
                           "(nothing more was written)")


CORPUS = str(ROOT / "datasets" / "corpus")


@pytest.mark.parametrize("flags,line", [
    (["--base", "nope"], "rap-farm: error: --base nope: no such part in hexagon (parts: hub, r0"),
    (["--model", "nosuch.pt"], "rap-farm: error: --model nosuch.pt: no such checkpoint"),
    (["--model", str(ROOT / "rap" / "data" / "default_model.pt")],
     f"rap-farm: error: --model {ROOT / 'rap' / 'data' / 'default_model.pt'}: trained on hexagon"),
], ids=["base", "model", "model-trained-on"])
def test_experiment_checks_its_input_in_the_command_body(run_cli, flags, line, tmp_path,
                                                         monkeypatch):
    """Past the parser: the command body reads the dataset and the assemblies, then refuses the
    value in one line, exit 2, before any simulation worker starts (a NameError here once made
    every experiment exit 4)."""
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli("experiment", CORPUS, "--only", "hexagon", "--assemblies",
                             str(ROOT / "assemblies"), *flags)
    assert (code, out) == (2, ""), err
    assert err.startswith(line) and len(err.strip().splitlines()) == 1, err
    assert not any(tmp_path.iterdir())

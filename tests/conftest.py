"""Shared test fixtures (keep this small): run the ``rap-farm`` CLI in-process; the order and the
pytest-xdist groups of the tests; shared resources stopped once no test needs them.

The default run (pyproject.toml: ``-n 2 --dist loadgroup``) spreads the tests over two
pytest-xdist workers by group: the tests on Ray (marked ``ray``) are one group, run one after
another by one worker, so that two Ray clusters never run at once; every other test module is a
group of its own (its module fixtures are built once). Among the tests marked ``ray`` those on the shared local
Ray (fixture ``ray_local``, tests/farm/conftest.py) run first, one after another, so that it
starts once (tests/shared_resources.py).

The groups reach pytest-xdist's controller through a file the workers write at collection
(``ByGroup`` below), not through ``xdist_group`` marks: pytest-xdist 3.8 passes those by editing
node ids, which pytest 9.2's structured node ids no longer allow (pytest-xdist issue 1386).
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # so that ``tests.*`` imports under the ``pytest`` script too
    sys.path.insert(0, str(ROOT))

from tests.shared_resources import note_items, stop_unused  # noqa: E402

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


def pytest_collection_modifyitems(config, items):
    """The tests on Ray in one block where the first of them was (first the modules with a test
    on ``ray_local``, in their order); in a pytest-xdist worker, the groups written for the
    controller. On Ray: marked ``ray``, except a test of a module on ``ray_local`` that does not
    use it (such a module's tests start no Ray of their own)."""
    shares = {getattr(i, "module", None) for i in items if "ray_local" in i.fixturenames}
    on_ray = {i for i in items if i.get_closest_marker("ray") is not None
              and ("ray_local" in i.fixturenames or getattr(i, "module", None) not in shares)}
    if on_ray:
        first = next(n for n, i in enumerate(items) if i in on_ray)
        rest = [i for i in items if i not in on_ray]
        block = sorted((i for i in items if i in on_ray),  # stable: modules stay whole
                       key=lambda i: getattr(i, "module", None) not in shares)
        items[:] = rest[:first] + block + rest[first:]
    note_items(items)
    path = getattr(config, "workerinput", {}).get("rap_test_groups")
    if path:  # every worker writes the same; whole or not at all
        groups = {i.nodeid: "ray" if i in on_ray else i.nodeid.split("::")[0] for i in items}
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path))
        with os.fdopen(fd, "w") as fh:
            json.dump(groups, fh)
        os.replace(tmp, path)


def pytest_configure(config):
    if not hasattr(config, "workerinput") and config.pluginmanager.hasplugin("xdist"):
        config.rap_test_groups = Path(tempfile.mkdtemp(prefix="rap-test-groups-")) / "groups.json"


def pytest_unconfigure(config):
    groups = getattr(config, "rap_test_groups", None)
    if groups is not None:
        shutil.rmtree(groups.parent, ignore_errors=True)


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):  # pytest-xdist, in the controller: where the groups go
    node.workerinput["rap_test_groups"] = str(node.config.rap_test_groups)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadgroup``: work units are the groups described above (a test missing from the
    workers' file is a unit of its own, or its ``xdist_group`` as pytest-xdist reads it)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadGroupScheduling

    class ByGroup(LoadGroupScheduling):
        groups: dict | None = None

        def _split_scope(self, nodeid: str) -> str:
            if self.groups is None:
                self.groups = json.loads(config.rap_test_groups.read_text())
            return self.groups.get(nodeid) or super()._split_scope(nodeid)

    return ByGroup(config, log)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item, nextitem):
    """After the test's own teardown: stop the shared resources that the next test will not use."""
    try:
        return (yield)
    finally:
        stop_unused(item, nextitem)

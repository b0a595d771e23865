"""Fixtures of the farm tests: one small local Ray shared by the modules that use it one after
another, stand-ins, tiny configurations.

Ray tests are marked ``@pytest.mark.ray`` (select: ``pytest -m ray``; skip: ``-m "not ray"``).
Every Ray started here gets a throwaway auth token through ``RAY_AUTH_TOKEN`` (token
authentication stays on; nothing is written to ``~/.ray``) and is shut down in teardown.
"""

from __future__ import annotations

import importlib.util
import os
import secrets
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # so that tests.farm.standin imports here and in Ray workers
    sys.path.insert(0, str(ROOT))

os.environ.setdefault("RAY_AUTH_TOKEN", secrets.token_hex(32))
os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")

from rap.farm.actors import Backend  # noqa: E402
from tests.shared_resources import shared  # noqa: E402

ASSEMBLIES = ROOT / "assemblies"

HAVE_RENDER = importlib.util.find_spec("rap.render.images") is not None
HAVE_SIM = importlib.util.find_spec("rap.sim.simulator") is not None
HAVE_GEOMETRY = all(importlib.util.find_spec(f"rap.geometry.{m}") is not None
                    for m in ("ndbg", "partitions", "andor"))

#: fast fake physics + fake images: for the farm's own logic (order, retries, resume)
FAKE = Backend(simulate="tests.farm.standin:simulate", render="tests.farm.standin:render",
               warm_up="")
#: the real simulator (few trials) with the real renderer when it exists
REAL = Backend(simulate="rap.sim.simulator:simulate",
               render="rap.render.images:render_pair" if HAVE_RENDER else "tests.farm.standin:render")


def ray_env() -> dict:
    """Environment for subprocesses that start or join Ray (same token, repo importable)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["RAY_AUTH_MODE"] = "token"
    return env


def _start_ray():
    import ray

    if ray.is_initialized():
        ray.shutdown()
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR",
             runtime_env={"env_vars": {"PYTHONPATH": str(ROOT)}})
    return ray


@pytest.fixture(scope="module")
def ray_local():
    """One small local Ray (2 CPUs), shared by the consecutive tests that use it: started by the
    first, shut down after the last (tests/shared_resources.py; tests/conftest.py runs the tests
    that use it one after another). A test that shuts it down gets a new one at the next module."""
    return shared("ray_local", _start_ray, lambda ray: ray.shutdown(),
                  alive=lambda ray: ray.is_initialized())


@pytest.fixture
def standin_enum():
    """The real operation selection (the geometry layer); the stand-in module for the rest."""
    from tests.farm import standin

    return standin


@pytest.fixture
def fake_enum(monkeypatch):
    """Always the stand-in selection (small, known operation lists)."""
    from tests.farm import standin

    import rap.labelling.selection as selection

    monkeypatch.setattr(selection, "select_operations", standin.select_operations)
    return standin

"""The planning service's tests share the farm's fixtures (a local Ray, its environment)."""

from tests.farm.conftest import ray_local  # noqa: F401  (a fixture, used by name)

"""Expensive test resources shared by the consecutive tests that use them: a local Ray, a running
``rap-farm serve``.

``shared(name, start, stop)`` returns the resource registered under a fixture's ``name``, started
by ``start()`` if it is not running (or ``alive(value)`` says it has gone). tests/conftest.py stops
it (``stop(value)``) at the end of a test after which the next test to run is in another module,
none of whose tests uses that fixture, and at the end of the run: so a module that used to start
its own Ray starts none when the module before it used one too, and two Ray clusters never run at
once (a test that starts its own runs after the shared one has stopped). ``stop`` may assert on
what the resource did; a failure is an error in the teardown of the test that used it last.

One registry per process (this module, imported by its name ``tests.shared_resources``; conftest
modules can be imported twice under two names, so they keep no state of their own).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

__all__ = ["Shared", "shared", "running", "note_items", "stop_unused"]


@dataclass
class Shared:
    """A resource started once for consecutive tests (``value``: what ``start`` returned)."""

    name: str
    start: Callable[[], Any]
    stop: Callable[[Any], None]
    alive: Callable[[Any], bool] = lambda value: True
    value: Any = None
    running: bool = False
    starts: int = field(default=0)  # how many times it was started in this process

    def get(self) -> Any:
        if not self.running or not self.alive(self.value):
            self.close()
            self.value, self.running = self.start(), True
            self.starts += 1
        return self.value

    def close(self) -> None:
        if self.running:
            value, self.value, self.running = self.value, None, False
            self.stop(value)


_REGISTRY: dict[str, Shared] = {}
_MODULE_FIXTURES: dict = {}  # module -> the names of the fixtures its collected tests use


def shared(name: str, start: Callable[[], Any], stop: Callable[[Any], None],
           alive: Callable[[Any], bool] | None = None) -> Any:
    """The running resource of fixture ``name`` (started now if needed)."""
    res = _REGISTRY.get(name)
    if res is None:
        res = _REGISTRY[name] = Shared(name, start, stop, alive or (lambda value: True))
    return res.get()


def running() -> list[Shared]:
    return [r for r in _REGISTRY.values() if r.running]


def note_items(items) -> None:
    """Record which fixtures the tests of each module use (the collected ``items``)."""
    _MODULE_FIXTURES.clear()
    for item in items:
        _MODULE_FIXTURES.setdefault(getattr(item, "module", None), set()).update(
            item.fixturenames)


def stop_unused(item, nextitem) -> None:
    """Stop each running resource that ``nextitem`` (None: the run ends) will not use: it is in
    another module than ``item`` and no test of its module uses the fixture (directly or through
    another fixture). Every resource is stopped even when one ``stop`` fails; the first failure
    is raised."""
    wanted: set = set()
    if nextitem is not None:
        module = getattr(nextitem, "module", None)
        if module is not None and module is getattr(item, "module", None):
            return
        wanted = _MODULE_FIXTURES.get(module) or set(nextitem.fixturenames)
    failure = None
    for res in running():
        if res.name in wanted:
            continue
        try:
            res.close()
        except BaseException as exc:  # noqa: BLE001  (raised below, after the others stopped)
            failure = failure or exc
    if failure is not None:
        raise failure

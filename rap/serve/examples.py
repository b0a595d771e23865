"""The example assemblies the planning page offers, without ray or fastapi: the package's own.

The examples are the reference assemblies shipped as package data (``rap/data/assemblies/*.json``,
there after ``pip install``), named by their file's stem. ``example_list()`` is ``[{"name",
"parts"}]`` sorted by name (``GET /examples``); ``example(name)`` is that assembly's JSON, as
``rap-farm import`` writes it (``GET /examples/{name}``), and raises ``UnknownExample`` (one line
naming the examples) for any other name: only names of the shipped list are looked up, so no path
is built from a request. The files are read and validated once, then kept (they are a few kB).
"""

from __future__ import annotations

import copy
import functools

from rap.assembly import SHIPPED_ASSEMBLIES, assembly_to_json
from rap.errors import InputError
from rap.io import load_assembly

__all__ = ["EXAMPLES_DIR", "UnknownExample", "example", "example_list"]

#: the reference assemblies shipped in the package
EXAMPLES_DIR = SHIPPED_ASSEMBLIES


class UnknownExample(InputError):
    """A name that is not one of the shipped examples (the service's 404)."""


@functools.lru_cache(maxsize=1)
def _examples() -> dict[str, dict]:
    return {p.stem: assembly_to_json(load_assembly(p)) for p in sorted(EXAMPLES_DIR.glob("*.json"))}


def example_list() -> list[dict]:
    """``[{"name": <file stem>, "parts": <number of parts>}]``, sorted by name."""
    return [{"name": name, "parts": len(doc["parts"])} for name, doc in _examples().items()]


def example(name: str) -> dict:
    """The assembly JSON of the shipped example ``name``; ``UnknownExample`` for another name."""
    docs = _examples()
    if name not in docs:
        shown = name if len(name) <= 60 else name[:59] + "…"
        raise UnknownExample(f"no example {shown!r}; the examples are {', '.join(docs)}")
    return copy.deepcopy(docs[name])

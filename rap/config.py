"""Helpers shared by the frozen configuration dataclasses (simulator parameters, model config)."""

from __future__ import annotations

from dataclasses import fields
from typing import TypeVar

__all__ = ["strict_from_dict"]

T = TypeVar("T")


def strict_from_dict(cls: type[T], data: dict, what: str) -> T:
    """``cls(**data)``, refusing keys that are not fields of ``cls`` (``ValueError`` naming them);
    missing keys take their defaults."""
    unknown = set(data) - {f.name for f in fields(cls)}
    if unknown:
        raise ValueError(f"unknown {what}: {sorted(unknown)}")
    return cls(**data)

"""Library errors name parameters, a command names its flags: ``flags`` maps one to the other.

    with flags("holdout", "max_rows", limit="--max-ops-per-assembly"):
        train(...)

A ``rap.errors.ParameterError`` raised inside whose parameter is listed becomes an ``InputError``
(exit 2) with the message naming the flag instead (``holdout 'nope': ...`` -> ``--holdout
'nope': ...``), after ``prefix``; any other exception passes through unchanged. ``flag(name)`` is
a parameter's flag by the CLI's convention: ``max_rows`` -> ``--max-rows``.
"""

from __future__ import annotations

from contextlib import contextmanager

from rap.errors import InputError, ParameterError

__all__ = ["flag", "flags"]


def flag(parameter: str) -> str:
    """The flag of ``parameter``: ``--`` and its name with dashes for underscores."""
    return "--" + parameter.replace("_", "-")


@contextmanager
def flags(*parameters: str, prefix: str = "", **renamed: str):
    """Map a ``ParameterError`` of one of ``parameters`` (flag by ``flag``) or of ``renamed``
    (parameter=flag) to the same one-line ``InputError`` naming the flag, after ``prefix``."""
    names = {p: flag(p) for p in parameters} | renamed
    try:
        yield
    except ParameterError as exc:
        name = names.get(getattr(exc, "parameter", None))  # (a Ray task's error may wrap it)
        if name is None:
            raise
        raise InputError(prefix + exc.for_name(name)) from None

"""Experiments behind the shipped defaults and docs/RESULTS.md; not part of the ``rap`` package.

Run from the repository root as modules (``python -m research.search_validation``); see
research/README.md. Nothing in ``rap`` imports this package.
"""

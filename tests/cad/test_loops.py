"""rap.cad.loops on plain drawn paths (no files): closed paths and open ones joined per layer."""

from __future__ import annotations

import pytest

from rap.cad.drawing import DrawnPath, Problem
from rap.cad.loops import join_loops

from .fixtures import src


def test_open_paths_join_within_their_layer_only():
    half1 = DrawnPath([[(0, 0), (10, 0)], [(10, 0), (10, 10)]], src("h1", 0, "L1"), False)
    half2 = DrawnPath([[(10, 10), (0, 10)], [(0, 10), (0, 0)]], src("h2", 1, "L1"), False)
    (loop,) = join_loops([half1, half2], 0.01, "mm")
    assert len(loop.pieces) == 4 and loop.source.ident == "h1"
    half2 = DrawnPath(half2.pieces, src("h2", 1, "L2"), False)
    with pytest.raises(Problem, match=r"open loop.*gap to the nearest free end.* is 14\.14 mm"):
        join_loops([half1, half2], 0.01, "mm")

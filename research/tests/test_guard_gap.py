"""``research.variants.guard_gap``: the gap applies on an unfamiliar assembly only, and the search
then goes on past its settled choice."""

from __future__ import annotations

from pathlib import Path

import rap
from rap.geometry.families import generate
from rap.model.inference.operations import OperationPredictor
from rap.plan import plan
from rap.plan.scoring.cache import ScoreCache
from research.variants.guard_gap import GUARD_GAP, GuardGapSearchPlanner

SHIPPED = Path(rap.__file__).parent / "data" / "default_model.pt"


def test_the_gap_is_kept_on_an_unfamiliar_assembly_only():
    model = OperationPredictor.load(SHIPPED, engine="auto")
    cache = ScoreCache()
    arch = generate("arch", 1)  # a held-out shape kind the guard flags
    kept = plan(arch, GuardGapSearchPlanner(), model=model, cache=cache)
    bare = plan(arch, model=model, cache=cache)
    assert kept.stats["guard_gap"] == GUARD_GAP and kept.stats.get("gap") == GUARD_GAP
    assert kept.stats["stopped"] in ("gap", "bound", "budget")
    assert kept.stats["search_simulations"] > bare.stats["search_simulations"]
    assert kept.bound["gap"] < bare.bound["gap"] and kept.robustness >= bare.robustness
    asked = plan(arch, GuardGapSearchPlanner(gap=0.2), model=model, cache=cache)
    assert "guard_gap" not in asked.stats  # the user's gap rules
    wall = plan(generate("wall", 200), GuardGapSearchPlanner(), model=model, cache=ScoreCache())
    assert "guard_gap" not in wall.stats and "guard" not in wall.to_json()

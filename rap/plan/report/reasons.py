"""Why a step is (or is not) robust: the one or two geometric quantities that limit it, in words.

Under perpendicular actuation noise an insertion fails when the motion cannot deviate from its
direction without jamming. The descriptors the model already computes
(``rap.model.data.descriptors``) say how far it may: the width of the range of directions that
separate the two subassemblies and the margin of the chosen direction to the range's nearer end,
how deep the moving subassembly sits in the fixed one, how long the two slide along each other.
From them, in the assembly's units:

* **direction range** ``width`` degrees wide, with ``margin`` degrees to its nearer end (a single
  direction: "a single insertion direction");
* **clearance** ``depth * tan(margin)``: how far the motion may drift sideways over the depth of
  the insertion; for a straight peg centred in a straight hole it is exactly the side clearance;
* **depth**: how far the fixed subassembly reaches past the moving one's trailing end along the
  motion;
* **sliding contact**: the length of common boundary parallel to the motion.

**The rule.** Each quantity gets a *tightness*: its value over a typical value (``TYPICAL``) for
those that hurt as they grow (depth, sliding contact), the typical value over it for those that
help (margin, clearance); a single direction is infinitely tight. The typical values are the
medians over every operation of the six reference assemblies (``assemblies/*.json``, online
space, ``python -m research.benchmarks.reason_typicals`` prints them): a tightness above 1 means
"tighter than the usual operation". The step's reason names the two tightest quantities, the
tightest first (ties: in the order above); a step whose range is the whole circle (nothing
around it) is "free: nothing blocks any direction". A step whose moving parts touch nothing
along the insertion and at the goal is "free: no contact" (``FREE_REASON``, given by
``rap.plan.report.poses.annotate_plan`` without the descriptors). Numbers are rounded to 2
significant digits; a depth or contact under 1e-6 of the moving extent or perimeter (the
descriptors' float noise) counts as none.

Floats only (descriptors are floats; the reasons are words). Cost: the descriptors of one
operation (``DescriptorContext``: one NDBG per assembly, then about 0.3 ms an operation) and one
shapely union of the moving parts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rap.assembly import DEFAULT_UNITS
from rap.model.data.descriptors import DESCRIPTORS, DescriptorContext
from rap.operation import Operation

__all__ = ["TYPICAL", "Quantity", "step_quantities", "step_reason", "format_length",
           "FREE_REASON"]

#: typical values of the reference assemblies' operations (module doc): margin in degrees,
#: clearance and depth as fractions of the moving subassembly's extent, sliding contact as a
#: fraction of its perimeter
TYPICAL = {"margin_deg": 45.0, "clearance": 0.39, "depth": 0.41, "sliding": 0.087}
# measured: 2,089 online operations; medians over 1,853 (margin), 1,377 (clearance), 1,872 (depth)
# and 234 (sliding) operations where the quantity applies

_FREE = "free: nothing blocks any direction"
#: the reason of a free step: its moving parts touch nothing along the insertion or at the goal
#: (``rap.plan.problem.PlanningProblem.is_free``), robust by geometry, scored 1 unsimulated
FREE_REASON = "free: no contact"
#: lengths below this fraction of the moving extent are shapely's float noise, taken as 0
_NEGLIGIBLE = 1e-6


@dataclass(frozen=True)
class Quantity:
    """One named quantity of a step: ``name`` (``direction range``, ``clearance``, ``depth``,
    ``sliding contact``), its ``value`` (degrees for the range's margin, assembly units for the
    rest), ``text`` (the words shown) and ``tightness`` (module doc)."""

    name: str
    value: float
    text: str
    tightness: float


def format_length(value: float, units: str = DEFAULT_UNITS) -> str:
    """``value`` to 2 significant digits with its unit: "0.5 mm"; "0.5 units" for the default."""
    shown = f"{value:.2g}" if abs(value) < 1e4 else f"{value:.0f}"
    if "e" in shown:
        shown = f"{value:.6f}".rstrip("0").rstrip(".")
    return f"{shown} {'units' if units == DEFAULT_UNITS else units}"


def _degrees(value_deg: float) -> str:
    return f"{value_deg:.2g}" if value_deg < 10 else f"{value_deg:.0f}"


def _moving_shape(context: DescriptorContext, op: Operation) -> tuple[float, float]:
    """(extent, perimeter) of the moving subassembly: extent as the descriptors define it (the
    larger of its length along the motion and its width across), perimeter of its union."""
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    parts = [context.assembly.part(i) for i in sorted(op.moving)]
    union = unary_union([Polygon(p.float_outer(), p.float_holes()) for p in parts])
    dx, dy = op.direction
    along = [x * dx + y * dy for p in parts for x, y in p.float_outer()]
    across = [-x * dy + y * dx for p in parts for x, y in p.float_outer()]
    return max(max(along) - min(along), max(across) - min(across)), union.length


def step_quantities(context: DescriptorContext, op: Operation,
                    units: str = DEFAULT_UNITS) -> list[Quantity]:
    """The quantities of a feasible operation, tightest first (module doc); empty when the range
    is the whole circle. Raises ``ValueError`` when ``op`` is not feasible."""
    d = dict(zip(DESCRIPTORS, (float(v) for v in context.descriptors(op))))
    width, margin = d["range_width_rad"], d["margin_rad"]
    if width >= 2 * math.pi:
        return []
    extent, perimeter = _moving_shape(context, op)
    depth = d["depth"] * extent if d["depth"] > _NEGLIGIBLE else 0.0
    sliding = d["sliding_contact"] * perimeter if d["sliding_contact"] > _NEGLIGIBLE else 0.0
    out = []
    if d["single_direction"]:
        out.append(Quantity("direction range", 0.0, "a single insertion direction", math.inf))
    else:
        wd, md = math.degrees(width), math.degrees(margin)
        out.append(Quantity("direction range", md,
                            f"direction range {_degrees(wd)}° wide (margin {_degrees(md)}°)",
                            TYPICAL["margin_deg"] / md if md > 0 else math.inf))
        if depth > 0 and margin < math.pi / 2:
            clearance = depth * math.tan(margin)
            out.append(Quantity("clearance", clearance,
                                f"clearance {format_length(clearance, units)}",
                                TYPICAL["clearance"] * extent / clearance if clearance > 0
                                else math.inf))
    if depth > 0:
        out.append(Quantity("depth", depth, f"inserted {format_length(depth, units)} deep",
                            d["depth"] / TYPICAL["depth"]))
    if sliding > 0:
        out.append(Quantity("sliding contact", sliding,
                            f"sliding contact {format_length(sliding, units)}",
                            d["sliding_contact"] / TYPICAL["sliding"]))
    order = {q.name: k for k, q in enumerate(out)}
    return sorted(out, key=lambda q: (-q.tightness, order[q.name]))


def step_reason(context: DescriptorContext, op: Operation, units: str = DEFAULT_UNITS) -> str:
    """The step's reason: the two tightest quantities' words joined by "; " (module doc)."""
    qs = step_quantities(context, op, units)
    if not qs:
        return _FREE
    return "; ".join(q.text for q in qs[:2])

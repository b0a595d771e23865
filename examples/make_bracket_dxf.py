"""Write examples/bracket.dxf: a slotted bracket on a base plate, a peg with a filleted head in
the bracket's round-ended slot, and a spacer; millimetres, one part a layer.

    python examples/make_bracket_dxf.py          # rewrites examples/bracket.dxf

The drawing is committed; this script says how it was made (ezdxf, closed LWPOLYLINEs whose
bulges draw the arcs: bulge = tan(angle / 4), positive counterclockwise).
"""

from __future__ import annotations

import math
from pathlib import Path

import ezdxf

OUT = Path(__file__).resolve().parent / "bracket.dxf"
Q = math.tan(math.radians(90) / 4)  # a quarter-circle fillet, counterclockwise

# (x, y, bulge of the segment that starts at this vertex)
PARTS = {
    "plate": [(0, 0, 0), (120, 0, 0), (120, 10, 0), (0, 10, 0)],
    # a 16 mm slot from the top edge down to a round end (radius 8 about (60, 28)); R5 fillets
    "bracket": [(10, 10, 0), (110, 10, 0), (110, 45, Q), (105, 50, 0), (68, 50, 0), (68, 28, -1),
                (52, 28, 0), (52, 50, 0), (15, 50, Q), (10, 45, 0)],
    # a stem 0.2 mm narrower on each side than the slot, its end round (radius 7.8); a 36 x 10
    # head with R4 fillets resting on the bracket's top edge
    "peg": [(52.2, 28, 1), (67.8, 28, 0), (67.8, 50, 0), (78, 50, 0), (78, 56, Q), (74, 60, 0),
            (46, 60, Q), (42, 56, 0), (42, 50, 0), (52.2, 50, 0)],
    "spacer": [(110, 10, 0), (120, 10, 0), (120, 30, 0), (110, 30, 0)],
}


def main() -> None:
    doc = ezdxf.new("R2010", units=4)  # $INSUNITS 4: millimetres
    msp = doc.modelspace()
    for name, points in PARTS.items():
        doc.layers.add(name)
        msp.add_lwpolyline(points, format="xyb", close=True, dxfattribs={"layer": name})
    doc.saveas(OUT)
    print(OUT)


if __name__ == "__main__":
    main()

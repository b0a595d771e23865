"""Write the six reference assemblies to ``assemblies/*.json`` (integer coordinates).

Our own designs in the spirit of the paper's six puzzle-like assemblies (its figures are not
available): each is highly constrained, mixing wide funnels (chevrons, V-grooves, wedges) that
guide a part home with tight peg-in-hole insertions (rectangular tabs and slots that admit a
single direction). Run ``python scripts/make_assemblies.py`` to regenerate; the output is
deterministic.

- hexagon:      a hexagon; a keyed centre hub inside a ring of six trapezoids (7 parts).
- mixed-square: a tangram square (7 mixed pieces) dropped into a three-walled tray (8 parts).
- pentagons:    interlocking house-shaped pentagons on a slotted base plate (8 parts).
- rectilinear:  rectilinear parts with a C-shaped part and its peg (a forced peg-in-hole step)
                and an S-shaped part (9 parts).
- grid:         a 3 x 3 grid whose shared edges are chevrons, rectangular tabs or flat (9 parts).
- triangles:    a triangle cut into nine triangles: the inverted ones are locked by their three
                neighbours and need non-linear steps (several parts inserted at once) (9 parts).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from shapely.geometry import Polygon, box
from shapely.ops import unary_union

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "assemblies"
PACKAGED = ROOT / "rap" / "data" / "assemblies"  # the copies shipped in the wheel


def ring(poly: Polygon) -> list[list[int]]:
    """Exterior of an integer shapely polygon, without the closing point, collinear points removed."""
    pts = [(int(round(x)), int(round(y))) for x, y in poly.exterior.coords[:-1]]
    out = []
    n = len(pts)
    for i, p in enumerate(pts):
        a, c = pts[i - 1], pts[(i + 1) % n]
        if (p[0] - a[0]) * (c[1] - p[1]) - (p[1] - a[1]) * (c[0] - p[0]) != 0:
            out.append(list(p))
    return out


def part(pid: str, pts, holes=()) -> dict:
    d = {"id": pid, "polygon": [list(map(int, p)) for p in pts]}
    if holes:
        d["holes"] = [[list(map(int, p)) for p in h] for h in holes]
    return d


# ---------------------------------------------------------------------------------------------
def grid() -> dict:
    """3 x 3 cells of side 40; internal edges carry a profile: chevron, tab (tight) or flat."""
    L = 40
    chevron = [(0, 0), (8, 0), (20, 10), (32, 0), (40, 0)]  # wide V tooth: a funnel
    tab = [(0, 0), (14, 0), (14, 8), (26, 8), (26, 0), (40, 0)]  # rectangular key: tight
    flat = [(0, 0), (40, 0)]
    # vertical edge between column i and i+1 in row j: (profile, sign); +1 protrudes to +x
    vertical = {(0, 0): (chevron, +1), (1, 0): (chevron, -1),
                (0, 1): (tab, +1), (1, 1): (flat, 1),
                (0, 2): (chevron, -1), (1, 2): (tab, -1)}
    # horizontal edge between row j and j+1 in column i; +1 protrudes to +y
    horizontal = {(0, 0): (flat, 1), (0, 1): (chevron, +1),
                  (1, 0): (tab, +1), (1, 1): (chevron, -1),
                  (2, 0): (chevron, +1), (2, 1): (flat, 1)}

    def vedge(i, j):  # points bottom -> top on x = L*(i+1)
        if not 0 <= i < 2:
            x = 0 if i < 0 else 3 * L
            return [(x, L * j), (x, L * j + L)]
        prof, s = vertical[(i, j)]
        return [(L * (i + 1) + s * d, L * j + t) for t, d in prof]

    def hedge(i, j):  # points left -> right on y = L*(j+1)
        if not 0 <= j < 2:
            y = 0 if j < 0 else 3 * L
            return [(L * i, y), (L * i + L, y)]
        prof, s = horizontal[(i, j)]
        return [(L * i + t, L * (j + 1) + s * d) for t, d in prof]

    parts = []
    for j in range(3):
        for i in range(3):
            bottom = hedge(i, j - 1)
            right = vedge(i, j)
            top = list(reversed(hedge(i, j)))
            left = list(reversed(vedge(i - 1, j)))
            pts = []
            for seg in (bottom, right, top, left):
                for p in seg:
                    if not pts or pts[-1] != p:
                        pts.append(p)
            if pts[0] == pts[-1]:
                pts.pop()
            parts.append(part(f"g{j}{i}", ring(Polygon(pts))))
    return {"name": "grid", "parts": parts}


# ---------------------------------------------------------------------------------------------
def hexagon() -> dict:
    """Flat-topped hexagon: a hub with one tight key, surrounded by six trapezoids."""
    R, r = 60, 24  # outer and inner circumradius
    def hexpts(rad):
        return [(round(rad * math.cos(math.radians(60 * k))), round(rad * math.sin(math.radians(60 * k))))
                for k in range(6)]
    outer, inner = hexpts(R), hexpts(r)
    hub = Polygon(inner)
    # chevron teeth: the hub's edge k gets a V tooth into ring part k for odd k (funnels),
    # and a rectangular key into ring part 0 (tight peg-in-hole)
    ring_polys = [Polygon([inner[k], outer[k], outer[(k + 1) % 6], inner[(k + 1) % 6]]) for k in range(6)]
    for k in (0, 2, 4):  # slanted edges: V teeth, wide funnels
        a, b = inner[k], inner[(k + 1) % 6]
        mx, my = (a[0] + b[0]) / 2, (a[1] + b[1]) / 2
        n = math.hypot(mx, my)
        tip = (round(mx + 10 * mx / n), round(my + 10 * my / n))
        tooth = Polygon([a, tip, b])
        hub = hub.union(tooth)
        ring_polys[k] = ring_polys[k].difference(tooth)
    # the top edge (inner[1] -> inner[2]) is horizontal: a tight 6 x 8 rectangular key into r1
    key = box(-3, inner[1][1] - 6, 3, inner[1][1] + 8)
    hub = hub.union(key)
    ring_polys[1] = ring_polys[1].difference(key)
    parts = [part("hub", ring(hub.buffer(0)))]
    for k, p in enumerate(ring_polys):
        parts.append(part(f"r{k}", ring(p.buffer(0))))
    return {"name": "hexagon", "parts": parts}


# ---------------------------------------------------------------------------------------------
def pentagons() -> dict:
    """Up-houses on a slotted base plate; down-houses fill the V grooves between their roofs."""
    W, H, roof = 20, 20, 10
    plate_top = 0
    parts = []
    # base plate with one tight slot under house u1
    slot_x = (W + W // 2 - 3, W + W // 2 + 3)
    plate = Polygon([(-10, -12), (4 * W + 10, -12), (4 * W + 10, 0), (slot_x[1], 0), (slot_x[1], -6),
                     (slot_x[0], -6), (slot_x[0], 0), (-10, 0)])
    parts.append(part("base", ring(plate)))
    for k in range(4):
        x0 = k * W
        pts = [(x0, 0), (x0 + W, 0), (x0 + W, H), (x0 + W // 2, H + roof), (x0, H)]
        if k == 1:  # tight peg into the plate's slot
            pts = [(x0, 0), (slot_x[0], 0), (slot_x[0], -6), (slot_x[1], -6), (slot_x[1], 0),
                   (x0 + W, 0), (x0 + W, H), (x0 + W // 2, H + roof), (x0, H)]
        parts.append(part(f"u{k}", pts))
    for k in range(3):
        cx = (k + 1) * W
        pts = [(cx, H), (cx + W // 2, H + roof), (cx + W // 2, H + roof + H), (cx - W // 2, H + roof + H),
               (cx - W // 2, H + roof)]
        parts.append(part(f"d{k}", pts))
    return {"name": "pentagons", "parts": parts}


# ---------------------------------------------------------------------------------------------
def tangram_square() -> dict:
    """The seven tangram pieces of a 80 x 80 square in a three-walled tray."""
    s = 20
    pieces = {
        "big1": [(0, 0), (4, 0), (2, 2)],
        "big2": [(0, 0), (2, 2), (0, 4)],
        "mid": [(4, 2), (4, 4), (2, 4)],
        "sq": [(2, 2), (3, 1), (4, 2), (3, 3)],
        "tri1": [(3, 1), (4, 0), (4, 2)],
        "tri2": [(2, 2), (3, 3), (1, 3)],
        "para": [(1, 3), (3, 3), (2, 4), (0, 4)],
    }
    parts = []
    for pid, pts in pieces.items():
        parts.append(part(pid, [(x * s + 10, y * s + 10) for x, y in pts]))
    tray = Polygon([(0, 0), (100, 0), (100, 60), (90, 60), (90, 10), (10, 10), (10, 60), (0, 60)])
    parts.insert(0, part("tray", ring(tray)))
    return {"name": "mixed-square", "parts": parts}


# ---------------------------------------------------------------------------------------------
def rectilinear() -> dict:
    """Rectilinear parts on a 10-unit grid: a C-shaped part with its peg, an S-shaped part."""
    u = 10
    rows = [  # top row first; '.' is empty
        "AAAAAAAA",
        "SSBBCCCD",
        "ESSBPPCD",
        "EEBBCCCD",
        "FFFFFFFF",
    ]
    cells: dict[str, list] = {}
    for r, line in enumerate(rows):
        y = (len(rows) - 1 - r) * u
        for c, ch in enumerate(line):
            if ch != ".":
                cells.setdefault(ch, []).append(box(c * u, y, c * u + u, y + u))
    names = {"A": "top", "B": "bar", "C": "c-part", "D": "post", "E": "ell", "F": "floor",
             "P": "peg", "S": "s-part"}
    parts = []
    for ch in sorted(cells):
        poly = unary_union(cells[ch])
        assert isinstance(poly, Polygon) and not poly.interiors, ch
        parts.append(part(names[ch], ring(poly)))
    return {"name": "rectilinear", "parts": parts}


# ---------------------------------------------------------------------------------------------
def triangles() -> dict:
    """A triangle of side 60 cut into nine; the three inverted ones are locked individually."""
    def P(i, j):
        return (20 * i + 10 * j, 17 * j)
    parts = []
    k = 0
    for j in range(3):
        for i in range(3 - j):
            parts.append(part(f"t{k}", [P(i, j), P(i + 1, j), P(i, j + 1)]))
            k += 1
            if i + j + 1 < 3:
                parts.append(part(f"t{k}", [P(i + 1, j), P(i + 1, j + 1), P(i, j + 1)]))
                k += 1
    return {"name": "triangles", "parts": parts}


ALL = {"hexagon": hexagon, "mixed-square": tangram_square, "pentagons": pentagons,
       "rectilinear": rectilinear, "grid": grid, "triangles": triangles}


def check(doc: dict) -> None:
    polys = [Polygon(p["polygon"], p.get("holes", [])) for p in doc["parts"]]
    for p, q in zip(doc["parts"], polys):
        assert q.is_valid and q.area > 0, (doc["name"], p["id"])
    for i in range(len(polys)):
        for j in range(i + 1, len(polys)):
            inter = polys[i].intersection(polys[j]).area
            assert inter == 0, (doc["name"], doc["parts"][i]["id"], doc["parts"][j]["id"], inter)
    assert 5 <= len(polys) <= 12, (doc["name"], len(polys))


def dumps(doc: dict) -> str:
    """JSON with one part per line group and points inline (diff-friendly, easy to read)."""
    lines = ["{", f'  "name": {json.dumps(doc["name"])},', '  "family": "reference",', '  "parts": [']
    for k, p in enumerate(doc["parts"]):
        body = f'    {{"id": {json.dumps(p["id"])}, "polygon": {json.dumps(p["polygon"])}'
        if p.get("holes"):
            body += f', "holes": {json.dumps(p["holes"])}'
        lines.append(body + "}" + ("," if k < len(doc["parts"]) - 1 else ""))
    lines += ["  ]", "}"]
    return "\n".join(lines) + "\n"


def main() -> int:
    OUT.mkdir(exist_ok=True)
    PACKAGED.mkdir(parents=True, exist_ok=True)
    for name, make in ALL.items():
        doc = make()
        check(doc)
        for d in (OUT, PACKAGED):
            (d / f"{name}.json").write_text(dumps(doc))
        print(f"{name}: {len(doc['parts'])} parts")
    return 0


if __name__ == "__main__":
    sys.exit(main())

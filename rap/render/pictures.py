"""Pictures for people: an assembly with its NDBG circle, and a plan storyboard.

matplotlib (Agg) only; floats only. ``draw_parts`` is the one routine that puts parts on axes, used
by every picture here. Output format follows the file suffix (``.png`` or ``.svg``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Iterable, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import PathPatch, Wedge  # noqa: E402
from matplotlib.path import Path as MPath  # noqa: E402
from shapely.geometry import Polygon  # noqa: E402

from rap.assembly import Assembly  # noqa: E402
from rap.errors import InputError  # noqa: E402

__all__ = ["draw_parts", "assembly_figure", "storyboard", "save_figure", "part_colors"]

_PALETTE = plt.get_cmap("tab20").colors


def part_colors(assembly: Assembly) -> dict[str, tuple]:
    """A stable colour per part id (by index in the assembly)."""
    return {pid: _PALETTE[(2 * i) % 20 if i < 10 else (2 * i + 1) % 20] for i, pid in enumerate(assembly.ids)}


def _part_path(part, dx: float = 0.0, dy: float = 0.0) -> MPath:
    verts, codes = [], []
    for ring in part.rings():
        pts = [(float(x) + dx, float(y) + dy) for x, y in ring]
        verts += pts + [pts[0]]
        codes += [MPath.MOVETO] + [MPath.LINETO] * (len(pts) - 1) + [MPath.CLOSEPOLY]
    return MPath(verts, codes)


def draw_parts(ax, assembly: Assembly, ids: Iterable[str] | None = None, offset=(0.0, 0.0),
               colors: dict | None = None, alpha: float = 1.0, labels: bool = True,
               edgecolor="black", linestyle="-", fontsize: float = 8) -> None:
    """Draw the parts ``ids`` (default: all) translated by ``offset`` on matplotlib axes."""
    colors = colors or part_colors(assembly)
    for pid in (assembly.ids if ids is None else ids):
        part = assembly.part(pid)
        ax.add_patch(PathPatch(_part_path(part, *offset), facecolor=colors[pid], edgecolor=edgecolor,
                               linewidth=0.8, alpha=alpha, linestyle=linestyle))
        if labels:  # a point inside the part (a C-shape's vertex mean lies in its mouth)
            inside = Polygon(part.float_outer(), part.float_holes()).representative_point()
            cx, cy = inside.x + offset[0], inside.y + offset[1]
            ax.text(cx, cy, pid, ha="center", va="center", fontsize=fontsize, alpha=alpha)


def _frame(ax, bounds, pad=0.08):
    x0, y0, x1, y1 = bounds
    p = pad * max(x1 - x0, y1 - y0)
    ax.set_xlim(x0 - p, x1 + p)
    ax.set_ylim(y0 - p, y1 + p)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def save_figure(fig, path: str | Path) -> Path:
    """Save as PNG or SVG by suffix; raises InputError for another suffix or an unwritable path."""
    path = Path(path)
    if path.suffix.lower() not in (".png", ".svg"):
        raise InputError(f"{path}: picture must end in .png or .svg")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=110, bbox_inches="tight")
    except OSError as exc:
        raise InputError(f"{path}: cannot write picture ({exc.strerror or exc})") from None
    finally:
        plt.close(fig)
    return path


def assembly_figure(assembly: Assembly, cells: Sequence, counts: Sequence[int], path: str | Path,
                    title: str | None = None) -> Path:
    """The assembly with part ids, and its NDBG circle beside it.

    ``cells``: NDBG cells in CCW order (``kind``, ``unit``); ``counts[k]``: how many partitions of
    the whole assembly cell k admits. Arcs are shaded by that count; vertices are ticks coloured
    the same way; cells admitting none are white.
    """
    fig, (ax, axc) = plt.subplots(1, 2, figsize=(11, 5.2), gridspec_kw={"width_ratios": [1.25, 1]})
    draw_parts(ax, assembly)
    _frame(ax, assembly.bounds())
    ax.set_title(title or f"{assembly.name}: {len(assembly)} parts")

    cmap = plt.get_cmap("viridis")
    top = max([1, *counts])
    angles = [math.degrees(math.atan2(c.unit[1], c.unit[0])) % 360 for c in cells]
    vert = [i for i, c in enumerate(cells) if c.kind == "vertex"]
    vangle = {i: angles[i] for i in vert}
    n = len(cells)
    for i, c in enumerate(cells):
        colour = "white" if counts[i] == 0 else cmap(0.15 + 0.85 * counts[i] / top)
        if c.kind == "arc":
            if not vert:
                start, end = 0.0, 360.0
            else:
                start = vangle[(i - 1) % n] if cells[(i - 1) % n].kind == "vertex" else angles[i] - 1
                end = vangle[(i + 1) % n] if cells[(i + 1) % n].kind == "vertex" else angles[i] + 1
                if end <= start:
                    end += 360
            axc.add_patch(Wedge((0, 0), 1.0, start, end, width=0.28, facecolor=colour,
                                edgecolor="0.6", linewidth=0.4))
    for i in vert:
        a = math.radians(vangle[i])
        colour = "0.85" if counts[i] == 0 else cmap(0.15 + 0.85 * counts[i] / top)
        axc.plot([0.66 * math.cos(a), 1.08 * math.cos(a)], [0.66 * math.sin(a), 1.08 * math.sin(a)],
                 color=colour, linewidth=1.6)
        axc.plot([0.66 * math.cos(a), 1.08 * math.cos(a)], [0.66 * math.sin(a), 1.08 * math.sin(a)],
                 color="black", linewidth=0.3)
    axc.annotate("", xy=(0.5, 0), xytext=(0, 0), arrowprops=dict(arrowstyle="->", color="0.4"))
    axc.text(0.52, 0.03, "0", fontsize=7, color="0.4")
    _frame(axc, (-1.1, -1.1, 1.1, 1.1), pad=0.05)
    sm = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0, top))
    fig.colorbar(sm, ax=axc, fraction=0.046, pad=0.04, label="partitions of the whole admitted")
    axc.set_title(f"NDBG: {len(vert)} vertices, {n - len(vert)} arcs\n(removal directions; "
                  f"removal = -insertion)")
    return save_figure(fig, path)


def storyboard(assembly: Assembly, steps: Sequence, path: str | Path, title: str = "",
               robust_threshold: float = 0.95, gap: float | None = None) -> Path:
    """One panel per assembly step: parts already placed, the moving subassembly drawn at a
    distance back along its motion (dashed) and in place, an arrow of motion and the score.

    ``steps``: objects with ``moving``, ``fixed`` (id collections), ``direction`` (the insertion:
    unit vector the moving subassembly travels along to its place), ``score`` (float or None),
    ``source`` and optionally ``score_interval`` (shown after the score).
    Steps whose score is below ``robust_threshold`` are marked in red.
    """
    k = len(steps)
    cols = min(4, max(1, k))
    rows = math.ceil(k / cols) if k else 1
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 3.6 * rows), squeeze=False)
    x0, y0, x1, y1 = assembly.bounds()
    size = max(x1 - x0, y1 - y0)
    gap = gap if gap is not None else 0.45 * size
    colors = part_colors(assembly)
    for idx, ax in enumerate(axes.flat):
        if idx >= k:
            ax.axis("off")
            continue
        st = steps[idx]
        dx, dy = st.direction
        back = (-dx * gap, -dy * gap)
        draw_parts(ax, assembly, sorted(st.fixed), colors=colors, fontsize=6)
        draw_parts(ax, assembly, sorted(st.moving), colors=colors, alpha=0.35, offset=back,
                   labels=False, linestyle="--")
        draw_parts(ax, assembly, sorted(st.moving), colors=colors, fontsize=6)
        bx0, by0, bx1, by1 = assembly.subset_bounds(list(st.moving) + list(st.fixed))
        cx, cy = (bx0 + bx1) / 2, (by0 + by1) / 2
        ax.annotate("", xy=(cx, cy), xytext=(cx + back[0], cy + back[1]),
                    arrowprops=dict(arrowstyle="-|>", color="black", linewidth=1.5))
        bad = st.score is not None and st.score < robust_threshold
        score = "?" if st.score is None else f"{st.score:.2f}"
        lo_hi = getattr(st, "score_interval", None)  # the step's 95% interval, when known
        score += "" if lo_hi is None else f" ({lo_hi[0]:.2f}-{lo_hi[1]:.2f})"
        src = f" [{st.source}]" if getattr(st, "source", None) else ""
        ax.set_title(f"step {idx + 1}: r = {score}{src}" + ("  NOT ROBUST" if bad else ""),
                     fontsize=9, color="crimson" if bad else "black")
        if bad:
            for s in ax.spines.values():
                s.set_edgecolor("crimson")
                s.set_linewidth(2.5)
        _frame(ax, (min(x0, x0 + back[0]), min(y0, y0 + back[1]), max(x1, x1 + back[0]), max(y1, y1 + back[1])))
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)

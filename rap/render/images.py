"""Start/goal image pairs of assembly operations for the CNN (Pillow + numpy; no torch, no pymunk).

``render_pair(assembly, operation, params=None, size=64) -> uint8 [2, size, size]``: channel 0 is
the start configuration (the moving subassembly at its start offset, ``rap.sim.placement``), channel
1 the goal (assembled) configuration, both in one frame that fits the union of start and goal with
a margin. The view is rotated so that the moving subassembly translates DOWNWARD in the image (rows
increase downward): the paper's normalisation, so a CNN sees every operation in the same
orientation. Fixed parts are drawn at ``FIXED`` (255), moving parts at ``MOVING`` (128) on black
(0). Anti-aliased: drawn at ``SUPERSAMPLE`` x the size with ``ImageDraw.polygon`` (holes drawn in
background colour; parts drawn largest box first, so a part lying in another's hole stays) and
reduced with a box filter. Deterministic: the same input gives the same bytes.

``render_crop(assembly, operation, ...) -> uint8 [2, size, size]``: a close-up of the mating
region in the same orientation: a window of ``CROP_CONTEXT`` times the moving subassembly's larger
extent, centred on where it ends; channel 0 shows it on its approach (``CROP_APPROACH`` extents
back along the motion), channel 1 in place. At 64 pixels for the whole operation a clearance of
1-3 units is under a pixel; here it is several. ``render_view(..., view)`` gives the channels a
network was trained on: ``"pair"`` (2 channels) or ``"pair+crop"`` (4: the pair, then the crop).

Cost: O(vertices) per image plus the rasterisation of a (4 size)^2 canvas.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np
from PIL import Image, ImageDraw

from rap.assembly import Assembly
from rap.operation import Operation
from rap.sim.params import DEFAULT_PARAMS
from rap.sim.placement import placement

__all__ = ["render_pair", "render_crop", "render_view", "view_channels", "VIEWS", "render_many",
           "render_masks", "render_start_goal_png", "view_transform", "FIXED", "MOVING",
           "SUPERSAMPLE", "MARGIN", "CROP_CONTEXT", "CROP_APPROACH"]

FIXED = 255
MOVING = 128
SUPERSAMPLE = 4
MARGIN = 0.06  # fraction of the image left free on each side
CROP_CONTEXT = 2.0  # the close-up's window side, x the moving subassembly's larger extent
CROP_APPROACH = 0.5  # the close-up's approach pose: this many extents back along the motion
VIEWS = {"pair": 2, "pair+crop": 4}  # view -> channels


def _rotation(direction: tuple[float, float]) -> tuple[float, float, float, float]:
    """Rotation (y-up coordinates) taking ``direction`` to (0, -1): image-down."""
    theta = -math.pi / 2 - math.atan2(direction[1], direction[0])
    c, s = math.cos(theta), math.sin(theta)
    return c, -s, s, c


def _parts(assembly: Assembly, ids: Iterable[str]):
    return [assembly.part(i) for i in sorted(ids)]


def view_transform(assembly: Assembly, operation: Operation, params=None, size: int = 64):
    """``(to_pixel, offset)``: a function mapping an (N, 2) array of assembly points (moving
    points already translated) to image pixel coordinates (x right, y down) at ``size``, and the
    start offset of the moving subassembly (assembly units)."""
    p = params if params is not None else DEFAULT_PARAMS
    pl = placement(assembly, operation, p.start_gap)
    a, b, c, d = _rotation(operation.direction)
    R = np.array([[a, b], [c, d]])
    off = np.array(pl.start_offset)
    fixed = np.concatenate([part.float_arrays()[0] for part in _parts(assembly, operation.fixed)])
    moving = np.concatenate([part.float_arrays()[0] for part in _parts(assembly, operation.moving)])
    pts = np.concatenate([fixed, moving, moving + off]) @ R.T
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = max(hi[0] - lo[0], hi[1] - lo[1])
    k = size * (1 - 2 * MARGIN) / span
    mid = (lo + hi) / 2
    half = size / 2

    def to_pixel(xy: np.ndarray) -> np.ndarray:
        q = (np.asarray(xy, dtype=float) @ R.T - mid) * k
        out = np.empty_like(q)
        np.add(half, q[:, 0], out=out[:, 0])
        np.subtract(half, q[:, 1], out=out[:, 1])
        return out

    return to_pixel, tuple(off)


def _layers(to_pixel, layers) -> list[tuple]:
    """``[(value, part, translation)]`` -> drawable items (supersampled pixel rings as flat
    coordinate lists), computed once so that a part drawn in several images is transformed once.
    Every ring goes through ``to_pixel`` in one call (the same arithmetic per point as a call per
    ring)."""
    rings = [ring + shift for _, part, shift in layers for ring in part.float_arrays()]
    if not rings:
        return []
    px = to_pixel(np.concatenate(rings)) * SUPERSAMPLE
    flat = px.ravel().tolist()
    items, at = [], 0
    for value, part, _ in layers:
        coords = []
        for ring in part.float_arrays():
            if not coords:  # the outer ring's pixel box orders the drawing
                outer = px[at:at + len(ring)]
                area = float(np.prod(outer.max(axis=0) - outer.min(axis=0)))
            coords.append(flat[2 * at:2 * (at + len(ring))])
            at += len(ring)
        items.append((-area, part.id, value, coords[0], coords[1:]))
    return items


def _draw(to_pixel, layers, size: int) -> np.ndarray:
    """Rasterise ``[(value, part, translation)]`` anti-aliased; uint8 [size, size]."""
    return _draw_items(_layers(to_pixel, layers), size)


def _draw_items(items: list[tuple], size: int) -> np.ndarray:
    """Rasterise ``_layers`` items, largest box first (ties by part id), holes in background."""
    big = size * SUPERSAMPLE
    img = Image.new("L", (big, big), 0)
    draw = ImageDraw.Draw(img)
    for _, _, value, outer, holes in sorted(items, key=lambda t: (t[0], t[1])):
        draw.polygon(outer, fill=value)
        for h in holes:
            draw.polygon(h, fill=0)
    small = img.resize((size, size), Image.BOX)
    return np.frombuffer(small.tobytes(), dtype=np.uint8).reshape(size, size)


def render_pair(assembly: Assembly, operation: Operation, params=None, size: int = 64) -> np.ndarray:
    """uint8 [2, size, size]: start (channel 0) and goal (channel 1), motion pointing down."""
    to_pixel, off = view_transform(assembly, operation, params, size)
    zero = np.zeros(2)
    shift = np.array(off)
    fixed = _layers(to_pixel, [(FIXED, part, zero) for part in _parts(assembly, operation.fixed)])
    mov = _parts(assembly, operation.moving)
    start = _draw_items(fixed + _layers(to_pixel, [(MOVING, part, shift) for part in mov]), size)
    goal = _draw_items(fixed + _layers(to_pixel, [(MOVING, part, zero) for part in mov]), size)
    return np.stack([start, goal])


def render_crop(assembly: Assembly, operation: Operation, params=None, size: int = 64,
                context: float = CROP_CONTEXT, approach: float = CROP_APPROACH) -> np.ndarray:
    """uint8 [2, size, size]: the mating region close up (see the module docstring)."""
    a, b, c, d = _rotation(operation.direction)
    R = np.array([[a, b], [c, d]])
    mov_parts = _parts(assembly, operation.moving)
    moving = np.array([xy for part in mov_parts for xy in part.float_outer()]) @ R.T
    lo, hi = moving.min(axis=0), moving.max(axis=0)
    extent = float(max(hi[0] - lo[0], hi[1] - lo[1]))
    k = size / (context * extent)
    mid = (lo + hi) / 2

    def to_pixel(xy: np.ndarray) -> np.ndarray:
        q = (np.asarray(xy, dtype=float) @ R.T - mid) * k
        return np.stack([size / 2 + q[:, 0], size / 2 - q[:, 1]], axis=1)

    back = -approach * extent * np.asarray(operation.direction, dtype=float)
    zero = np.zeros(2)
    fixed = _layers(to_pixel, [(FIXED, part, zero) for part in _parts(assembly, operation.fixed)])
    near = _draw_items(fixed + _layers(to_pixel, [(MOVING, part, back) for part in mov_parts]),
                       size)
    goal = _draw_items(fixed + _layers(to_pixel, [(MOVING, part, zero) for part in mov_parts]),
                       size)
    return np.stack([near, goal])


def render_view(assembly: Assembly, operation: Operation, view: str = "pair", params=None,
                size: int = 64) -> np.ndarray:
    """uint8 [VIEWS[view], size, size]: the pair, or the pair and the close-up."""
    if view == "pair":
        return render_pair(assembly, operation, params, size)
    if view == "pair+crop":
        return np.concatenate([render_pair(assembly, operation, params, size),
                               render_crop(assembly, operation, params, size)])
    raise ValueError(f"view must be one of {list(VIEWS)}, not {view!r}")


def view_channels(view: str) -> int:
    try:
        return VIEWS[view]
    except KeyError:
        raise ValueError(f"view must be one of {list(VIEWS)}, not {view!r}") from None


def render_masks(assembly: Assembly, operation: Operation, params=None, size: int = 64) -> np.ndarray:
    """float [2, 2, size, size] in [0, 1]: (start, goal) x (fixed, moving) coverage, same frame as
    ``render_pair`` (for tests and analysis)."""
    to_pixel, off = view_transform(assembly, operation, params, size)
    zero, shift = np.zeros(2), np.array(off)
    out = np.zeros((2, 2, size, size))
    for ch, sh in ((0, shift), (1, zero)):
        out[ch, 0] = _draw(to_pixel, [(255, p, zero) for p in _parts(assembly, operation.fixed)],
                           size) / 255.0
        out[ch, 1] = _draw(to_pixel, [(255, p, sh) for p in _parts(assembly, operation.moving)],
                           size) / 255.0
    return out


def render_many(assembly: Assembly, operations: Sequence[Operation], params=None,
                size: int = 64) -> np.ndarray:
    """uint8 [N, 2, size, size] for many operations of one assembly."""
    out = np.empty((len(operations), 2, size, size), dtype=np.uint8)
    for i, op in enumerate(operations):
        out[i] = render_pair(assembly, op, params, size)
    return out


def render_start_goal_png(assembly: Assembly, operation: Operation, path: str | Path, params=None,
                          size: int = 256) -> Path:
    """Write the pair side by side (start | goal) as a greyscale PNG for people; returns the path."""
    pair = render_pair(assembly, operation, params, size)
    gap = max(2, size // 32)
    canvas = np.full((size, 2 * size + gap), 64, dtype=np.uint8)
    canvas[:, :size] = pair[0]
    canvas[:, size + gap:] = pair[1]
    path = Path(path)
    Image.fromarray(canvas, mode="L").save(path, format="PNG")
    return path

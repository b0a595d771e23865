"""Animated GIF of a few noisy simulator trials (Pillow; no pymunk import here beyond the tracer).

Fixed parts are drawn grey, the moving subassembly of each traced trial in its own colour (green
outline when that trial succeeded, red when it failed), and the planned straight path as a line
from the start to the goal of the moving subassembly's centroid. Assembly coordinates, y up.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from rap.assembly import Assembly
from rap.operation import Operation

__all__ = ["write_trials_gif", "COLOURS"]

COLOURS = [(66, 133, 244), (251, 188, 5), (171, 71, 188), (0, 172, 193), (255, 112, 67),
           (124, 179, 66)]
_FIXED = (150, 150, 150)
_BG = (255, 255, 255)


def write_trials_gif(assembly: Assembly, operation: Operation, path: str | Path, params=None,
                     rng: np.random.Generator | None = None, k: int = 4, size: int = 360,
                     every: int = 4, max_frames: int = 150) -> Path:
    """Simulate (as ``simulate`` would, same rng) and write trials ``0..k-1`` as a GIF."""
    from rap.sim.trace import trace

    tr = trace(assembly, operation, params, rng, k=k, every=every)
    poses = tr.poses
    stride = max(1, int(np.ceil(poses.shape[1] / max_frames)))
    frames_idx = list(range(0, poses.shape[1], stride))
    if frames_idx[-1] != poses.shape[1] - 1:
        frames_idx.append(poses.shape[1] - 1)
    fixed = [assembly.part(i) for i in sorted(operation.fixed)]
    moving = [assembly.part(i) for i in sorted(operation.moving)]
    pivot = np.array(tr.pivot)

    def placed(part, pose):
        ox, oy, ang = pose
        c, s = np.cos(ang), np.sin(ang)
        rot = np.array([[c, -s], [s, c]])
        rings = [np.array(part.float_outer())] + [np.array(h) for h in part.float_holes()]
        return [(r - pivot) @ rot.T + pivot + (ox, oy) for r in rings]

    # frame: everything that is ever drawn
    pts = [np.array(p.float_outer()) for p in fixed]
    for t in range(poses.shape[0]):
        for f in (0, poses.shape[1] - 1):
            pts += [placed(p, poses[t, f])[0] for p in moving]
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    scale = size * 0.9 / max(hi[0] - lo[0], hi[1] - lo[1])
    mid = (lo + hi) / 2

    def px(xy):
        q = (np.asarray(xy) - mid) * scale
        return [(size / 2 + x, size / 2 - y) for x, y in q]

    start = pivot + np.array(tr.start_offset)
    images = []
    for f in frames_idx:
        img = Image.new("RGB", (size, size), _BG)
        dr = ImageDraw.Draw(img)
        for part in fixed:
            dr.polygon(px(part.float_outer()), fill=_FIXED, outline=(90, 90, 90))
            for h in part.float_holes():
                dr.polygon(px(h), fill=_BG, outline=(90, 90, 90))
        dr.line(px([start, pivot]), fill=(0, 160, 0), width=2)
        for t in range(poses.shape[0]):
            col = COLOURS[t % len(COLOURS)]
            done = f >= tr.decided_frame[t]
            edge = ((0, 140, 0) if tr.outcomes[t] else (200, 0, 0)) if done else (40, 40, 40)
            for part in moving:
                rings = placed(part, poses[t, f])
                dr.polygon(px(rings[0]), fill=col, outline=edge)
                for h in rings[1:]:
                    dr.polygon(px(h), fill=_BG, outline=edge)
        dr.text((6, 6), f"t = {f * tr.frame_dt_s:5.2f} s", fill=(0, 0, 0))
        images.append(img.quantize(colors=64, dither=Image.Dither.NONE))
    path = Path(path)
    duration = max(20, int(round(1000 * tr.frame_dt_s * stride)))
    images[0].save(path, format="GIF", save_all=True, append_images=images[1:], duration=duration,
                   loop=0, disposal=2)
    return path

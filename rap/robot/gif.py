"""Pictures of the arm simulation: a fixed camera on the cell, and an animated GIF (Pillow).

``camera(program, width, height)`` returns a function ``world -> PIL.Image`` that renders a
pybullet world with its software renderer (TinyRenderer: no GL, works in DIRECT mode) from a
point in front of the assembly's plane, to the side and above, looking at it, so the arm, the
tray and the assembly are in view. ``write_gif(frames, path, frame_s)`` writes the frames as a
looping GIF atomically (an adaptive palette per frame). Cost: about 10-40 ms a frame at 320 x 240.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

__all__ = ["camera", "write_gif"]


def camera(program, width: int = 320, height: int = 240):
    """A renderer of worlds that hold ``program``'s cell (module doc)."""
    fr = program.frame
    target = fr.origin + np.array([0.0, 0.06, 0.07])
    eye = target + np.array([0.3, -0.5, 0.3])

    def shoot(world):
        from PIL import Image

        view = world.computeViewMatrix(list(map(float, eye)), list(map(float, target)), [0, 0, 1])
        proj = world.computeProjectionMatrixFOV(45, width / height, 0.05, 5.0)
        _, _, rgba, _, _ = world.getCameraImage(width, height, view, proj,
                                                renderer=world.ER_TINY_RENDERER)
        arr = np.reshape(np.asarray(rgba, dtype=np.uint8), (height, width, 4))[:, :, :3]
        return Image.fromarray(arr)

    return shoot


def write_gif(frames, path: str | Path, frame_s: float = 0.12, max_frames: int = 200) -> Path:
    """Write ``frames`` (PIL images) as a looping GIF at ``path``, atomically; at most
    ``max_frames`` of them, evenly spaced, the last one kept (a 22-step wall records about 1000:
    2.4 MB; 200 are under 0.5 MB)."""
    from rap.files import write_bytes_atomic

    if not frames:
        raise ValueError("no frames to write")
    if len(frames) > max_frames:
        pick = np.linspace(0, len(frames) - 1, max_frames).round().astype(int)
        frames = [frames[i] for i in pick]
    path = Path(path)
    buf = io.BytesIO()
    pal = [f.convert("P", palette=1, colors=64) for f in frames]  # 1 = Image.ADAPTIVE
    pal[0].save(buf, format="GIF", save_all=True, append_images=pal[1:],
                duration=int(frame_s * 1000), loop=0, optimize=True)
    return write_bytes_atomic(path, buf.getvalue())

"""Animated GIF of noisy trials."""

from __future__ import annotations

import numpy as np
from PIL import Image

from rap.render.gif import write_trials_gif
from rap.sim.params import SimParams

from .test_images import CASES


def test_gif_has_frames(tmp_path):
    a, o = CASES["funnel_peg"]
    path = write_trials_gif(a, o, tmp_path / "t.gif", SimParams(trials=6), np.random.default_rng(2),
                            k=2, size=120, max_frames=30)
    with Image.open(path) as im:
        assert im.format == "GIF" and 2 <= im.n_frames <= 31

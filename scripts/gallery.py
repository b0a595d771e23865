"""Draw a few assemblies of every family into one picture (``docs/gallery.png``).

One row per family, ``--per-family`` assemblies (seeds 0, 1, ...) with the default options, each
titled with its name and part count; parts coloured by ``rap.render.pictures.draw_parts``.

    python scripts/gallery.py                       # docs/gallery.png
    python scripts/gallery.py --per-family 6 -o /tmp/gallery.png --labels
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from rap.geometry.families import FAMILIES, generate  # noqa: E402
from rap.render.pictures import draw_parts  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", default=str(ROOT / "docs" / "gallery.png"))
    ap.add_argument("--per-family", type=int, default=5)
    ap.add_argument("--labels", action="store_true", help="write part ids on the parts")
    ap.add_argument("--dpi", type=int, default=60)
    args = ap.parse_args(argv)
    names = list(FAMILIES)
    k = args.per_family
    fig, axes = plt.subplots(len(names), k, figsize=(2.6 * k, 2.6 * len(names)), squeeze=False)
    for row, name in enumerate(names):
        for col in range(k):
            ax = axes[row][col]
            asm = generate(name, col)
            draw_parts(ax, asm, labels=args.labels, fontsize=5)
            x0, y0, x1, y1 = asm.bounds()
            pad = 0.04 * max(x1 - x0, y1 - y0)
            ax.set_xlim(x0 - pad, x1 + pad)
            ax.set_ylim(y0 - pad, y1 + pad)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"{asm.name} ({len(asm)} parts)", fontsize=9)
        axes[row][0].set_ylabel(name, fontsize=11)
    fig.suptitle("rap-farm assembly families (python scripts/gallery.py)", fontsize=12)
    fig.tight_layout(rect=(0, 0, 1, 0.985))
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.stem + ".tmp" + out.suffix)
    fig.savefig(tmp, dpi=args.dpi)
    plt.close(fig)
    tmp.replace(out)
    print(f"wrote {out} ({out.stat().st_size // 1024} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

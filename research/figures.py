"""The experiments' figures written one way: laid out, the folder made, saved at 90 dpi, said."""

from __future__ import annotations

from pathlib import Path


def save_figure(fig, path: str | Path) -> Path:
    """``fig`` (matplotlib) laid out tight and written to ``path``; prints where it went."""
    path = Path(path)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90, bbox_inches="tight")
    print(f"wrote {path}")
    return path

"""Small file-system helpers shared by writers (no third-party imports, so cheap to import)."""

from __future__ import annotations

import os

__all__ = ["committed_file_mode"]


def committed_file_mode() -> int:
    """Permissions of a committed file: 0o666 minus the process umask (``mkstemp`` makes 0o600)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask

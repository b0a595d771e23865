"""Small file-system helpers shared by writers (no third-party imports, so cheap to import).

``committed_file_mode()``: the mode a committed file gets (0o666 minus the umask);
``write_text_atomic(path, text)`` / ``write_bytes_atomic(path, data)``: a file written whole or not at all (temporary file beside
it, that mode, fsync, rename), so a reader (another user, a robot controller) never sees half a
file and can read it under the usual umask 022 (mode 0o644).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

__all__ = ["committed_file_mode", "write_text_atomic", "write_bytes_atomic"]


def committed_file_mode() -> int:
    """Permissions of a committed file: 0o666 minus the process umask (``mkstemp`` makes 0o600)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def write_text_atomic(path: str | Path, text: str, *, newline: str | None = None) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically with ``committed_file_mode()``: a temporary
    file in the same directory (created with its parents), flushed and fsync'ed, renamed into
    place. ``newline``: as ``open``'s (``""`` for CSV). Raises ``OSError``; the temporary file is
    removed on failure. Cost: one write of ``text``."""
    return _atomic(path, text, "w", encoding="utf-8", newline=newline)


def write_bytes_atomic(path: str | Path, data: bytes) -> Path:
    """``write_text_atomic`` for bytes (a GIF, a program file)."""
    return _atomic(path, data, "wb")


def _atomic(path: str | Path, data, mode: str, **open_kw) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=path.suffix, dir=path.parent)
    try:
        os.fchmod(fd, committed_file_mode())  # mkstemp makes 0o600
        with os.fdopen(fd, mode, **open_kw) as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path

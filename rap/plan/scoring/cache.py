"""A content-keyed cache of simulator scores, shared by planners, runs and processes.

Keys are ``PlanningProblem.key(op)``: the operation's content key (geometry hash, moving and fixed
sets, direction, simulator parameters' fingerprint) combined with the root seed, i.e. the dataset
key of the labelling farm. The per-operation simulator seed derives from the same key, so a cached
score is exactly the score a fresh simulation would give: the cache only saves time.

``ScoreCache(path)`` keeps entries in memory and, with a path, in one small JSON file
(``{"format": "rap-farm/score-cache", "version": 1, "scores": {key: [score, successes, trials]}}``).
``flush()`` re-reads the file, merges (entries are immutable, so the union is always right) and
writes a temporary file in the same directory that is renamed into place: a reader never sees a
half-written file and two runs flushing at once lose nothing but, at worst, each other's newest
entries (recomputed later, identically). Thread-safe. ``ScoreCache(None)`` is memory only.

Default location: ``$RAP_CACHE`` or ``$XDG_CACHE_HOME/rap-farm/scores.json`` (``~/.cache/...``).
No ray, no torch.
"""

from __future__ import annotations

import json
import os
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

from rap.files import committed_file_mode

__all__ = ["CachedScore", "ScoreCache", "default_cache_path", "CACHE_FORMAT"]

CACHE_FORMAT = "rap-farm/score-cache"
_VERSION = 1


@dataclass(frozen=True)
class CachedScore:
    score: float
    successes: int
    trials: int


def default_cache_path() -> Path:
    env = os.environ.get("RAP_CACHE")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "rap-farm" / "scores.json"


def _read(path: Path) -> dict[str, CachedScore]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return {}
    except (OSError, ValueError):
        return {}  # an unreadable cache is only a lost speed-up; it is rewritten on flush
    if not isinstance(data, dict) or data.get("format") != CACHE_FORMAT or data.get("version") != _VERSION:
        return {}
    out = {}
    for k, v in (data.get("scores") or {}).items():
        try:
            out[str(k)] = CachedScore(float(v[0]), int(v[1]), int(v[2]))
        except (TypeError, ValueError, IndexError):
            continue
    return out


class ScoreCache:
    """Scores by key, in memory and optionally in a JSON file (see module doc)."""

    def __init__(self, path: str | Path | None = None):
        self.path = Path(path).expanduser() if path is not None else None
        self._lock = threading.Lock()
        self._data: dict[str, CachedScore] = _read(self.path) if self.path else {}
        self._dirty = False

    def __len__(self) -> int:
        return len(self._data)

    def __contains__(self, key: str) -> bool:
        return key in self._data

    def get(self, key: str) -> CachedScore | None:
        return self._data.get(key)

    def get_many(self, keys: Iterable[str]) -> list[CachedScore | None]:
        with self._lock:
            return [self._data.get(k) for k in keys]

    def items(self) -> list[tuple[str, CachedScore]]:
        with self._lock:
            return list(self._data.items())

    def put(self, key: str, value: CachedScore) -> None:
        with self._lock:
            if key not in self._data:
                self._data[key] = value
                self._dirty = True

    def put_many(self, items: Iterable[tuple[str, CachedScore]]) -> None:
        with self._lock:
            for k, v in items:
                if k not in self._data:
                    self._data[k] = v
                    self._dirty = True

    def flush(self) -> Path | None:
        """Merge with the file and write it atomically; returns the path (None: memory only)."""
        if self.path is None:
            return None
        with self._lock:
            if not self._dirty:
                return self.path
            merged = _read(self.path)
            merged.update(self._data)
            self._data = merged
            doc = {"format": CACHE_FORMAT, "version": _VERSION,
                   "scores": {k: [v.score, v.successes, v.trials] for k, v in sorted(merged.items())}}
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".json", dir=self.path.parent)
            os.fchmod(fd, committed_file_mode())  # mkstemp makes 0o600
            try:
                with os.fdopen(fd, "w", encoding="utf-8") as fh:
                    json.dump(doc, fh, separators=(",", ":"))
                    fh.flush()
                    os.fsync(fh.fileno())
                os.replace(tmp, self.path)
            except BaseException:
                Path(tmp).unlink(missing_ok=True)
                raise
            self._dirty = False
        return self.path

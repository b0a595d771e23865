"""One writer per dataset: an advisory lock on ``DIR/_rapfarm.lock`` naming its holder."""

from __future__ import annotations

import errno
import json
import os
import socket
import time
import weakref
from dataclasses import dataclass, field
from pathlib import Path

from rap.errors import WorkFailedError
from rap.files import committed_file_mode

from rap.dataset.schema import LOCK_FILE
from rap.dataset.storage import storage_error


class DatasetBusyError(WorkFailedError):
    """Another process is writing the dataset: one line naming it (pid, host, start, command).
    Exit status 3 (run again once it has finished); nothing is written."""


_NO_FLOCK = {errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOTSUP, errno.ENOSYS, errno.EINVAL}


@dataclass(eq=False)
class DatasetLock:
    """The advisory lock of one writer on a dataset directory (``lock_dataset``): ``release()``
    (or leaving a ``with`` block, or the object being collected, or the process ending) unlinks
    the lock file and releases it, and removes the directories ``lock_dataset`` created when they
    are still empty."""

    root: Path
    path: Path
    owner: dict
    _finalizer: weakref.finalize | None = field(default=None, repr=False)

    @property
    def held(self) -> bool:
        return self._finalizer is not None and self._finalizer.alive

    def release(self) -> None:
        if self._finalizer is not None:
            self._finalizer()

    def __enter__(self) -> "DatasetLock":
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def _describe_owner(text: str) -> str:
    """``pid 123 on HOST, started 2026-01-01T00:00:00+0000: rap-farm label ...`` (a lock file's)."""
    try:
        d = json.loads(text)
        head = f"pid {int(d['pid'])} on {d['host']}"
    except (ValueError, TypeError, KeyError, RecursionError):
        return "a process that has not written its pid and host yet"
    started = f", started {d['started']}" if d.get("started") else ""
    command = " ".join(str(d.get("command") or "").split())
    if len(command) > 120:
        command = command[:119] + "…"
    return head + started + (f": {command}" if command else "")


def _busy(root: Path, text: str) -> DatasetBusyError:
    return DatasetBusyError(f"{root}: another run is writing this dataset "
                            f"({_describe_owner(text)}); nothing was done: run again once it has "
                            f"finished, or choose another --out")


def _read_text(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="replace")[:4096]
    except OSError:
        return ""


def _pid_alive(pid: int) -> bool:
    if pid <= 0:  # not a process (0, -N: process groups)
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _flock(path: Path, text: str, root: Path) -> int | None:
    """The fd of ``path`` with an exclusive ``flock`` held and ``text`` written in it; None when
    the file system has no ``flock``. Raises ``DatasetBusyError`` when another process holds it."""
    import fcntl

    for _ in range(16):  # a holder that releases unlinks the file we may have opened: open again
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, committed_file_mode())
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise _busy(root, _read_text(path)) from None
        except OSError as exc:
            os.close(fd)
            if exc.errno in _NO_FLOCK:
                return None
            raise
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(path))
        except FileNotFoundError:
            same = False
        if same:
            _write_owner(fd, path, text)
            return fd
        os.close(fd)
    raise _busy(root, _read_text(path))


def _write_owner(fd: int, path: Path, text: str) -> None:
    """Write the holder's details into the lock file ``path`` open at ``fd``; on failure (a full
    disk) remove and close it, which releases the lock, and raise."""
    try:
        os.ftruncate(fd, 0)
        os.write(fd, text.encode())
    except OSError:
        _unlock(fd, path, [])
        raise


def _exclusive(path: Path, text: str, root: Path) -> int:
    """Without ``flock``: create ``path`` exclusively; a file left by a dead process of this host
    (pid no longer alive) is stale and taken over. Raises ``DatasetBusyError`` otherwise."""
    for _ in range(2):
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC,
                         committed_file_mode())
        except FileExistsError:
            held = _read_text(path)
            try:
                d = json.loads(held)
                stale = d["host"] == socket.gethostname() and not _pid_alive(int(d["pid"]))
            except (ValueError, TypeError, KeyError, RecursionError):
                stale = False
            if not stale:
                raise _busy(root, held) from None
            path.unlink(missing_ok=True)
            continue
        _write_owner(fd, path, text)
        return fd
    raise _busy(root, _read_text(path))


def _unlock(fd: int, path: Path, created: list[Path]) -> None:
    try:
        if os.path.samestat(os.fstat(fd), os.stat(path)):
            os.unlink(path)
    except OSError:
        pass
    finally:
        os.close(fd)  # releases the flock
    _remove_empty(created)


def lock_dataset(root: str | Path, command: str = "") -> DatasetLock:
    """Take the one-writer lock of the dataset at ``root`` (created, with its parents, when
    missing; removed again on release while still empty). Writes ``{"pid", "host", "started",
    "command"}`` into ``root/_rapfarm.lock``. Raises ``DatasetBusyError`` (one line naming the
    holder) when another process, or another lock in this one, holds it; ``StorageError`` when
    the directory or the file cannot be made. Cost: a few system calls."""
    root = Path(root)
    created: list[Path] = []
    d = root
    while not d.exists() and d.parent != d:
        created.append(d)
        d = d.parent
    created.reverse()  # the topmost first
    path = root / LOCK_FILE
    owner = {"pid": os.getpid(), "host": socket.gethostname(),
             "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "command": command}
    text = json.dumps(owner) + "\n"
    try:
        for c in created:
            c.mkdir()
        fd = _flock(path, text, root)
        if fd is None:
            fd = _exclusive(path, text, root)
    except OSError as exc:
        _remove_empty(created)
        raise storage_error(path, exc) from None
    except BaseException:
        _remove_empty(created)
        raise
    lock = DatasetLock(root, path, owner)
    lock._finalizer = weakref.finalize(lock, _unlock, fd, path, created)
    return lock


def _remove_empty(created: list[Path]) -> None:
    """Remove the directories ``lock_dataset`` made (topmost first in ``created``), the deepest
    first, while they are empty."""
    for d in reversed(created):
        try:
            d.rmdir()
        except OSError:
            break



"""User-facing errors and the CLI's documented exit statuses.

=====  =====================================================================================
 0     success
 1     no feasible sequence (``plan``: an interlocked subassembly or a blocking constraint is
       named)
 2     invalid input or usage: one line naming the file, the part or entity and the problem;
       nothing already written is touched
 3     the work failed: labelling failed for some assemblies, the simulation workers did not
       start, or a file could not be written (disk full, read-only); committed work is kept
 4     internal error (a bug in rap-farm): one line; ``RAP_DEBUG=1`` shows the traceback
130    interrupted (Ctrl-C, SIGTERM): committed work is kept
=====  =====================================================================================

SIGTERM as Ctrl-C, in one place: ``docker stop``, systemd, Kubernetes, SLURM and ``ray job stop``
send SIGTERM, and what runs under them stops as it does on Ctrl-C (commit, then stop). Inside
``sigterm_as_interrupt()`` a SIGTERM raises ``KeyboardInterrupt`` in the main thread and ignores
any later SIGTERM, so the cleanup after the first is not interrupted; the handler before the block
is put back after it. An interrupt that Python would drop (raised where an exception cannot go on:
an at-fork hook, a finalizer, a weakref callback; "Exception ignored in ...") is raised again in
the main thread instead (``sys.unraisablehook``), so the command never goes on deaf to it. A signal
handler lives in the main thread only: elsewhere the block changes nothing. The CLI's ``main`` and
the farm driver use it.
"""

from __future__ import annotations

import _thread
import contextlib
import signal
import sys
import threading
import time
from typing import Iterator

__all__ = ["RapError", "InputError", "ParameterError", "WorkFailedError", "StorageError", "one_line", "EXIT_OK",
           "EXIT_INFEASIBLE", "EXIT_INPUT", "EXIT_FAILED", "EXIT_INTERNAL", "EXIT_INTERRUPTED",
           "sigterm_as_interrupt"]

EXIT_OK = 0
EXIT_INFEASIBLE = 1  # no sequence / interlocked (plan)
EXIT_INPUT = 2  # invalid input: one-line error, nothing written
EXIT_FAILED = 3  # the work failed (labelling, workers, storage); committed work kept
EXIT_INTERNAL = 4  # an internal error: a bug, never a user's mistake
EXIT_INTERRUPTED = 130  # Ctrl-C or SIGTERM (serve: 0, it drains): committed work kept


class RapError(Exception):
    """Base class of errors shown to users as one line (never a traceback)."""

    exit_code = EXIT_INPUT


class InputError(RapError):
    """Bad input: a file, an option or a dataset that cannot be used. Exit status 2."""


class ParameterError(InputError, ValueError):
    """A library call's ``parameter`` given a ``value`` it refuses, and why (``reason``). The
    message names the parameter (``trust 0.0: choose a score in (0, 1]``); a command shows
    ``for_name(its flag)`` instead (``--trust 0.0: ...``). A text value is quoted (``method
    'bogus'``) unless ``quote=False`` (a name, a path or an address shown as given). Exit
    status 2."""

    def __init__(self, parameter: str, value, reason: str, *, quote: bool = True):
        self.parameter, self.value, self.reason, self.quote = parameter, value, reason, quote
        super().__init__(self.for_name(parameter))

    def for_name(self, name: str) -> str:
        """The message with ``name`` (e.g. a command's flag) in place of the parameter's."""
        shown = repr(self.value) if self.quote and isinstance(self.value, str) else self.value
        return f"{name} {shown}: {self.reason}"


class WorkFailedError(RapError):
    """Work that could not be done although the input was valid. Exit status 3."""

    exit_code = EXIT_FAILED


class StorageError(WorkFailedError):
    """A file could not be written (disk full, read-only, permissions): one line saying where.
    Exit status 3; what was committed before stays intact and no temporary file is left."""


def one_line(exc: BaseException) -> str:
    """An exception as one line of at most 200 characters: its message's first line (its type's
    name when it has none; "nested too deeply" for a ``RecursionError``)."""
    if isinstance(exc, RecursionError):
        return "nested too deeply"
    text = str(exc).strip().splitlines()
    line = text[0] if text else type(exc).__name__
    return line if len(line) <= 200 else line[:199] + "…"


def _interrupt(signum, frame) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # once: the cleanup runs to its end
    raise KeyboardInterrupt


@contextlib.contextmanager
def sigterm_as_interrupt(*, keep: bool = False) -> Iterator[None]:
    """SIGTERM raises ``KeyboardInterrupt`` for the duration of the block (module doc).

    ``keep=True``: a Python handler the caller already installed (the CLI's) is kept as it is."""
    if (threading.current_thread() is not threading.main_thread()
            or (keep and callable(signal.getsignal(signal.SIGTERM)))):
        yield
        return
    before = signal.signal(signal.SIGTERM, _interrupt)
    hook_before = sys.unraisablehook
    sys.unraisablehook = _redeliver(hook_before)
    try:
        yield
    finally:  # a caller in this process (a test) gets its own handler back
        sys.unraisablehook = hook_before
        if before is not None:
            signal.signal(signal.SIGTERM, before)


def _redeliver(previous):
    """An unraisable-exception hook that raises a dropped ``KeyboardInterrupt`` again in the main
    thread and passes anything else to ``previous``.

    The interrupt comes back through SIGTERM's slot, not SIGINT's: in the main thread, where a
    signal's interrupt is dropped, the hook installs a one-shot handler for SIGTERM (it puts back
    the disposition it found, then raises ``KeyboardInterrupt``) and a thread of its own fires it
    10 ms later with ``_thread.interrupt_main(SIGTERM)``, once the hook has returned (raised
    inside the hook, it would be dropped again). ``interrupt_main`` does nothing for a signal
    that Python does not handle, and a command started in the background by a shell without job
    control (``rap-farm label ... &`` in a script, ``nohup``) inherits SIGINT ignored; SIGTERM's
    handler is this module's own. Outside the main thread (no signal handler can be installed
    there) the interrupt comes back as Ctrl-C, where SIGINT is handled."""

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            try:
                signum = signal.SIGINT
                if threading.current_thread() is threading.main_thread():
                    signal.signal(signal.SIGTERM, _one_shot(signal.getsignal(signal.SIGTERM)))
                    signum = signal.SIGTERM
                _thread.start_new_thread(_interrupt_main_soon, (signum,))
                return
            except RuntimeError:  # the interpreter is shutting down: the interrupt has no use
                pass
        previous(unraisable)

    return hook


def _one_shot(disposition):
    """A SIGTERM handler that puts ``disposition`` back, then raises ``KeyboardInterrupt``."""

    def handler(signum, frame) -> None:
        signal.signal(signal.SIGTERM, disposition if disposition is not None else signal.SIG_DFL)
        raise KeyboardInterrupt

    return handler


def _interrupt_main_soon(signum: int) -> None:
    time.sleep(0.01)
    _thread.interrupt_main(signum)

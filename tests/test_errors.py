"""rap.errors.sigterm_as_interrupt: SIGTERM as Ctrl-C, shared by the CLI and the farm driver."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from rap.errors import sigterm_as_interrupt


def _own(signum, frame) -> None:
    raise AssertionError("the caller's handler ran")


@pytest.fixture
def own_handler():
    before = signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


def test_sigterm_raises_keyboard_interrupt_once_and_the_handler_comes_back(own_handler):
    signal.signal(signal.SIGTERM, _own)
    with pytest.raises(KeyboardInterrupt):
        with sigterm_as_interrupt():
            os.kill(os.getpid(), signal.SIGTERM)
    assert signal.getsignal(signal.SIGTERM) is _own


def test_a_second_sigterm_does_not_interrupt_the_cleanup(own_handler):
    cleaned = False
    with pytest.raises(KeyboardInterrupt):
        with sigterm_as_interrupt():
            try:
                os.kill(os.getpid(), signal.SIGTERM)
            finally:
                os.kill(os.getpid(), signal.SIGTERM)  # ignored
                cleaned = True
    assert cleaned
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_keep_leaves_a_handler_the_caller_installed(own_handler):
    signal.signal(signal.SIGTERM, _own)
    with sigterm_as_interrupt(keep=True):
        assert signal.getsignal(signal.SIGTERM) is _own
    with sigterm_as_interrupt():
        assert signal.getsignal(signal.SIGTERM) is not _own
    assert signal.getsignal(signal.SIGTERM) is _own


def test_keep_installs_when_no_python_handler_is_there(own_handler):
    with pytest.raises(KeyboardInterrupt):
        with sigterm_as_interrupt(keep=True):
            os.kill(os.getpid(), signal.SIGTERM)
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_outside_the_main_thread_nothing_changes(own_handler):
    seen = []

    def run():
        with sigterm_as_interrupt():
            seen.append(signal.getsignal(signal.SIGTERM))

    t = threading.Thread(target=run)
    t.start()
    t.join()
    assert seen == [signal.SIG_DFL]


class _DropsAnInterrupt:
    def __del__(self):
        raise KeyboardInterrupt  # where Python cannot raise it: "Exception ignored in ..."


def test_an_interrupt_python_would_drop_is_raised_again_in_the_main_thread(own_handler):
    """A KeyboardInterrupt raised in a finalizer (or an at-fork hook, a weakref callback) is
    dropped by Python; inside the block it reaches the main thread as Ctrl-C, so the command
    does not go on deaf to the SIGTERM it stood for."""
    import sys

    hook = sys.unraisablehook
    with pytest.raises(KeyboardInterrupt):
        with sigterm_as_interrupt():
            _DropsAnInterrupt()  # collected at once: its __del__'s interrupt is dropped
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:  # the eval loop takes the pending interrupt here
                pass
            pytest.fail("the dropped interrupt did not reach the main thread in 30 s")
    assert sys.unraisablehook is hook


@pytest.fixture
def sigint_ignored():
    """SIGINT ignored, as a command started in the background by a shell without job control
    (``rap-farm label ... &`` in a script, ``nohup``) inherits it."""
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


@pytest.mark.parametrize("interrupted_by", ["SIGTERM", "a finalizer"])
def test_a_dropped_interrupt_comes_back_with_sigint_ignored(own_handler, sigint_ignored,
                                                            interrupted_by):
    """Found by a test run started in the background: ``_thread.interrupt_main()`` (Ctrl-C) does
    nothing where SIGINT is ignored; the interrupt comes back through SIGTERM's slot. Whether
    it came from a SIGTERM (whose handler then ignores the next) or not, the block raises it once
    and leaves SIGINT ignored and SIGTERM's disposition as it was before the block."""
    with pytest.raises(KeyboardInterrupt):
        with sigterm_as_interrupt():
            if interrupted_by == "SIGTERM":
                with _Holder():
                    pass  # the handler's KeyboardInterrupt lands in __del__ and is dropped
            else:
                _DropsAnInterrupt()
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:
                pass
            pytest.fail("the dropped interrupt did not reach the main thread in 30 s")
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


class _Holder:
    """Sends this process SIGTERM from its finalizer and lets Python run the handler there: the
    handler's KeyboardInterrupt is raised inside ``__del__`` and dropped."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):  # the handler runs at one of these bytecodes
            pass


def test_other_unraisable_exceptions_still_reach_the_previous_hook(own_handler):
    import sys

    seen = []
    hook, sys.unraisablehook = sys.unraisablehook, lambda u: seen.append(u.exc_type)
    try:
        with sigterm_as_interrupt():

            class Fails:
                def __del__(self):
                    raise ValueError("in a finalizer")

            Fails()
        assert seen == [ValueError]
    finally:
        sys.unraisablehook = hook

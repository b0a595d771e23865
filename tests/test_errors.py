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

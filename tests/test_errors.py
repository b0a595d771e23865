"""rap.errors.sigterm_as_interrupt: SIGTERM as Ctrl-C, shared by the CLI and the farm driver."""

from __future__ import annotations

import os
import signal
import threading

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

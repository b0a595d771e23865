"""``rap.farm.runtime``: what Ray may say on the user's console when the farm starts it."""

from __future__ import annotations

import logging

import pytest

pytest.importorskip("ray")


def test_rays_default_token_notice_is_dropped_and_its_other_warnings_kept():
    """Ray's own warning functions (the installed version's text), through the logger that
    ``rap.farm.runtime`` filters: the "enabled by default" notice goes, the "disabled" warning
    (a cluster anyone on the network can use) stays."""
    import rap.farm.runtime  # noqa: F401  (installs the filter)
    from ray._private.authentication import authentication_token_setup as setup

    seen: list[logging.LogRecord] = []
    handler = logging.Handler()
    handler.emit = seen.append  # type: ignore[method-assign]
    log = logging.getLogger(setup.__name__)
    # another test's logging.config (uvicorn's, Serve's) may have disabled or raised this logger
    was = (log.disabled, log.level)
    log.disabled = False
    log.setLevel(logging.INFO)
    log.addHandler(handler)
    try:
        setup._warn_token_auth_enabled()
        setup._warn_token_auth_disabled()
    finally:
        log.removeHandler(handler)
        log.disabled, log.level = was
    assert [r.getMessage().split(".")[0] for r in seen] == [
        "Token authentication is disabled for this Ray cluster"]

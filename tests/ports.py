"""A free TCP port on 127.0.0.1 for a server a test starts (``free_port``).

Chosen below the kernel's ephemeral range (``/proc/sys/net/ipv4/ip_local_port_range``; Linux's
default starts at 32768) and above Ray's worker ports (10002-19999): every process that binds port
0 (Ray's gRPC servers, raylets, actors, starting beside the test and inside the server it starts)
gets an ephemeral port, so none of them can take this one between the choice and the server's
bind. A port from the ephemeral range was taken so once: the service's health check then read a
Ray gRPC server's bytes (``BadStatusLine``) and 61 tests of a run errored. Random (a generator of
its own, seeded by the process and the clock) so that the two test workers do not collide; each
candidate is checked by binding it.
"""

from __future__ import annotations

import os
import random
import socket
import time

__all__ = ["free_port"]

LOW = 20000  # above Ray's default worker ports (10002-19999)


def _ephemeral_low() -> int:
    try:
        with open("/proc/sys/net/ipv4/ip_local_port_range") as fh:
            return int(fh.read().split()[0])
    except (OSError, ValueError, IndexError):
        return 32768


def free_port() -> int:
    """A port on 127.0.0.1 that no socket holds now, outside the range the kernel hands out for
    port 0 (module doc); where that range leaves no room, one the kernel hands out."""
    high = _ephemeral_low() - 1
    rng = random.Random(os.getpid() * 1_000_003 + time.monotonic_ns())
    for _ in range(200 if high >= LOW else 0):
        port = rng.randint(LOW, high)
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]

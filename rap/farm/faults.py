"""Lost workers and failing batches: how ``SimPool`` tells them apart and how long it keeps trying.

A batch that does not come back is one of two things, and the pool treats them differently:

* **lost**: its actor or node went away (``ActorUnavailableError``, ``ActorDiedError``, a node's
  death, an object lost with its node, also when raised inside the task while it fetched its
  assembly). That is the weather of a cluster of spot or preemptible nodes, not a property of the
  batch: the batch is resubmitted to another started actor, at once after its first loss and
  then after a backoff (``backoff_s``: 0.2 s, doubling, at most 5 s), with no limit on the number
  of losses *as long as the pool makes progress*: it gives up on a batch only when it is lost
  again after no batch of the pool has completed for ``progress_timeout_s`` (``PROGRESS_TIMEOUT_S``,
  10 minutes; ``rap-farm label --progress-timeout``). A batch that crashes the actor process itself
  (a segfault in the simulator) looks lost too; it fails, named, once the rest of the run is done
  and that time has passed.
* **failed**: the simulation raised (a ``RayTaskError`` of any other cause). It may be the
  worker's fault (memory, a broken install on one node), so the batch is resubmitted to another
  actor, up to ``max_attempts`` submissions in all (3), then fails and its assembly is named, with
  the simulator's one-line error.

The pool counts both in ``SimPool.stats``: ``lost`` (batches lost with their workers),
``resubmitted`` (batches sent again, for either reason), ``redone_ops`` (operations sent again),
``retried`` (resubmissions after the simulator raised).

Test seam, no user-facing option: ``WorkerSet._fetch(ref)`` is the one place a task's result is
fetched (``ray.get``); a test replaces it to inject faults (``tests/farm/test_churn.py`` makes one
batch's actor unavailable five times in a row).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ray.exceptions import (ActorDiedError, ActorUnavailableError, NodeDiedError, ObjectLostError,
                            OwnerDiedError, RayActorError, RayTaskError, WorkerCrashedError)

__all__ = ["LOST", "PROGRESS_TIMEOUT_S", "BACKOFF_S", "BACKOFF_MAX_S", "MAX_ATTEMPTS", "Tries",
           "is_lost", "backoff_s", "cause_line"]

# a task's actor or node went away (its batch is resubmitted; never the simulator's own error)
LOST = (RayActorError, ActorDiedError, ActorUnavailableError, WorkerCrashedError, NodeDiedError,
        ObjectLostError, OwnerDiedError)

PROGRESS_TIMEOUT_S = 600.0  # no batch completed for this long: a lost batch is given up
BACKOFF_S = 0.2  # the wait before a batch's second submission after a loss; doubles each loss
BACKOFF_MAX_S = 5.0
MAX_ATTEMPTS = 3  # submissions of a batch whose simulation raises


@dataclass
class Tries:
    """A batch and what happened to it so far. ``avoid``: the actor that last lost or failed it;
    ``not_before``: monotonic time before which it is not sent again (backoff)."""

    task: Any  # rap.farm.actors.SimTask
    losses: int = 0
    failures: int = 0
    not_before: float = 0.0
    avoid: int | None = None

    @property
    def submissions(self) -> int:
        return self.losses + self.failures + 1


def is_lost(exc: BaseException) -> bool:
    """Whether ``exc`` (raised by ``ray.get`` of a task) means the task's worker or node went away,
    not that the task's own code failed."""
    if isinstance(exc, RayTaskError):
        return isinstance(getattr(exc, "cause", None), LOST)
    return isinstance(exc, LOST)


def backoff_s(losses: int, base_s: float = BACKOFF_S) -> float:
    """Seconds to wait before resubmitting a batch lost ``losses`` times: none after the first,
    then ``base_s``, doubling, at most ``BACKOFF_MAX_S``."""
    if losses <= 1:
        return 0.0
    return min(BACKOFF_MAX_S, base_s * 2.0 ** (losses - 2))


def cause_line(exc: BaseException) -> str:
    """The last line of what the task raised (the simulator's own error), else the type's name."""
    cause = getattr(exc, "cause", None)
    lines = str(cause if cause is not None else exc).strip().splitlines()
    return lines[-1] if lines else type(exc).__name__

"""Progress of the CLI's long commands (``plan``, ``inspect``, ``experiment``): one home.

``activity(label, console)`` is a transient one-line rich display on stderr, in ``label``'s style
(``rap.farm.driver``: bold label, then the figures, then the elapsed time) with a spinner in place
of a bar (these commands do not know their total in advance). It refreshes ten times a second from
the moment it is entered, so a long plan shows it within a second of starting, and it disappears
when done: the table, ``--out``, ``--csv`` and ``--json`` output are untouched. On a stderr that is
not a terminal (a pipe, a log file, a test) it shows nothing at all.

``Activity.update(text)`` sets the figures (``Activity.status(text)``: the same as a context manager,
in the shape of ``rich.console.Console.status``); ``Activity.scorer_progress`` is the callback a
``rap.plan.scoring.scorer.Scorer`` calls (``on_progress``) after each batch: operations scored by the
model, simulated, taken from the score cache, and the batch being simulated now.
"""

from __future__ import annotations

import contextlib
import sys

__all__ = ["activity", "Activity"]


class Activity:
    """A running display (see module doc); a no-op when disabled."""

    def __init__(self, label: str, console=None, enabled: bool | None = None):
        from rich.console import Console
        from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        self.console = console or Console(stderr=True)
        if enabled is None:
            enabled = self.console.is_terminal and self.console.file in (sys.stderr,
                                                                         sys.__stderr__)
        self.enabled = bool(enabled)
        self._progress = Progress(SpinnerColumn(), TextColumn(f"[bold]{label}"),
                                  TextColumn("{task.fields[text]}"), TimeElapsedColumn(),
                                  console=self.console, transient=True,
                                  disable=not self.enabled)
        self._task = self._progress.add_task(label, total=None, text="")

    def __enter__(self) -> "Activity":
        self._progress.start()
        return self

    def __exit__(self, *exc) -> bool:
        self._progress.stop()
        return False

    def update(self, text: str) -> None:
        """Show ``text`` after the label."""
        self._progress.update(self._task, text=text)

    @contextlib.contextmanager
    def status(self, text: str):
        """``Console.status``'s shape: show ``text`` while the block runs (so code written for a
        console's status line runs unchanged under an activity, with one live display)."""
        self.update(text)
        yield self

    def scorer_progress(self, stats, running: int = 0) -> None:
        """``Scorer.on_progress``: the scorer's counters (``ScorerStats``) and the operations
        being simulated now."""
        parts = []
        if stats.cnn_ops:
            parts.append(f"{stats.cnn_ops:,} operations scored by the model")
        parts.append(f"{stats.sim_run:,} simulated")
        if stats.cache_hits:
            parts.append(f"{stats.cache_hits:,} cached scores")
        if running:
            parts.append(f"simulating {running:,} now")
        self.update(", ".join(parts))


def activity(label: str, console=None, enabled: bool | None = None) -> Activity:
    """A transient progress line on ``console`` (default: a new stderr console); ``enabled``:
    None shows it only when that console writes to a terminal's stderr."""
    return Activity(label, console, enabled)

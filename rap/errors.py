"""User-facing errors and the CLI's documented exit statuses."""

__all__ = ["RapError", "InputError", "EXIT_OK", "EXIT_INFEASIBLE", "EXIT_INPUT", "EXIT_INTERRUPTED"]

EXIT_OK = 0
EXIT_INFEASIBLE = 1  # no sequence / interlocked (plan)
EXIT_INPUT = 2  # invalid input: one-line error, nothing written
EXIT_INTERRUPTED = 130  # Ctrl-C: committed work kept


class RapError(Exception):
    """Base class of errors shown to users as one line (never a traceback)."""

    exit_code = EXIT_INPUT


class InputError(RapError):
    """Bad input: a file, an option or a dataset that cannot be used. Exit status 2."""

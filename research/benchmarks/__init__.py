"""One-off investigations measured once (``python -m research.benchmarks.NAME``); the standing
benchmarks are in benchmarks/."""

"""Maintainer tool: what ``rap-farm plan`` answers, written for ``diff -r`` between two commits.

    python scripts/plan_identity.py OUT    # the ``rap`` imported (it says where from, on stderr)

Compare a commit with another (e.g. before a refactoring) through a worktree of the older one;
``diff -r`` prints nothing when they behave the same::

    git worktree add /tmp/base COMMIT
    PYTHONPATH=/tmp/base python scripts/plan_identity.py /tmp/plan_identity_base
    python scripts/plan_identity.py /tmp/plan_identity_new
    diff -r /tmp/plan_identity_base /tmp/plan_identity_new && git worktree remove /tmp/base

What it writes under OUT (everything with timings removed):

* ``plans/ASSEMBLY/VARIANT.json``: the ``--out`` document of ``rap-farm plan`` on each of the six
  reference assemblies (``assemblies/``) for every ``--method`` (and the default), plus variants
  that set every planner option, with the shipped model, ``--seed 7``, ``--trials 10``,
  ``--no-cache`` and one simulation process; ``VARIANT.txt`` is what the command printed (its
  ``time:`` line dropped);
* ``cli/``: ``plan --help``, ``experiment --help`` and the one-line answers (exit status, stderr)
  to invalid ``plan`` invocations;
* ``experiment_names.json``: the planner (class and attributes) or the error of each experiment
  method name (``rap-k2-p90``, ``search-s200-o10``, ...);
* ``api.json``: what the planning service's request parser (``rap.serve.api``) makes of valid and
  invalid ``options`` and methods.

BLAS runs on one thread, so that the model's confidences are the same to the last digit.

Runs in-process, in a few minutes on two cores. No ray.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import re
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# one BLAS thread: the numpy CNN engine changes its thread count with the load (cores_busy), and
# another summation order moves a confidence in its seventh digit
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"
ASSEMBLIES = ["hexagon", "mixed-square", "pentagons", "rectilinear", "grid", "triangles"]
COMMON = ["--seed", "7", "--trials", "10", "--no-cache", "--workers", "1"]
VARIANTS = {  # name -> extra ``plan`` arguments
    "default": [],
    "search": ["--method", "search"],
    "rap": ["--method", "rap"],
    "sim": ["--method", "sim"],
    "optimal": ["--method", "optimal"],
    "random": ["--method", "random", "--samples", "5"],
    "rap-options": ["--method", "rap", "--fallback-k", "2", "--high-probability", "0.5",
                    "--fallback-optimism", "1"],
    "rap-optimism": ["--method", "rap", "--fallback-optimism", "0.1"],
    "search-options": ["--method", "search", "--simulations", "20", "--trust", "0.97",
                       "--optimism", "0.4", "--beam-width", "2"],
    "sim-all": ["--method", "sim", "--space", "all"],
}
BAD_PLANS = [  # invalid ``plan`` invocations: exit status and the one line
    ["--method", "bogus"], ["--space", "bogus"], ["--trust", "0"], ["--trust", "1.5"],
    ["--high-probability", "0"], ["--high-probability", "2"], ["--fallback-k", "0"],
    ["--optimism", "2"], ["--fallback-optimism", "-1"], ["--beam-width", "0"],
    ["--simulations", "-1"], ["--samples", "0"], ["--out", "plan.txt"],
    ["--picture", "x.gif"], ["--no-ray", "--address", "auto"],
    ["--server", "http://127.0.0.1:1", "--trials", "5"],
    ["--server", "http://127.0.0.1:1", "--model", "m.pt"],
    ["--model", "missing.pt"], ["--trust", "0.9"],
]
EXPERIMENT_NAMES = [
    "random", "rap", "sim", "optimal", "search", "rap-paper", "rap-k2", "rap-p90", "rap-k2-p90",
    "rap-k1-o100", "rap-o10", "rap-p50-o100", "search-s200-o10", "search-w2-s10-b50",
    "search-s100-t97-o40", "search-w2", "search-s100-t97",
    "bogus", "rap-kx", "rap-k0", "rap-p0", "rap-p101", "rap-o101", "rap-k2-k3", "rap-q5",
    "search-x2", "search-w", "search-w0", "search-b0", "search-t0", "search-t101", "search-o101",
]
API_REQUESTS = [  # (method, options) sent to the service's parser
    ("search", {}), ("search", {"simulations": 200, "optimism": 0.1}),
    ("search", {"trust": 0.97, "beam_width": 3}), ("rap", {"fallback_k": 2}),
    ("rap", {"high_probability": 0.5, "fallback_optimism": 1}), ("sim", {}), ("optimal", {}),
    ("random", {}), (None, {}), ("bogus", {}), (7, {}),
    ("search", {"fallback_k": 2}), ("rap", {"simulations": 5}), ("sim", {"trust": 0.5}),
    ("search", {"simulations": 1.5}), ("search", {"simulations": True}),
    ("search", {"simulations": -1}), ("search", {"simulations": 5000}),
    ("search", {"trust": 0}), ("search", {"trust": 1.01}), ("search", {"optimism": 0}),
    ("search", {"beam_width": 0}), ("rap", {"high_probability": 0}), ("rap", {"fallback_k": 0}),
    ("search", {"bogus": 1}), ("search", []), ("rap", {"fallback_optimism": "0.5"}),
]


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    """``rap-farm ARGV`` in this process: (exit status, stdout, stderr)."""
    from rap.cli import main

    out, err = io.StringIO(), io.StringIO()
    status = 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            main(argv)
        except SystemExit as exc:
            status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    return status, out.getvalue(), err.getvalue()


def untimed(doc):
    """A plan document without its timing fields."""
    if isinstance(doc, dict):
        return {k: untimed(v) for k, v in doc.items() if k not in ("seconds", "eval_seconds")
                and not k.endswith("_seconds")}
    if isinstance(doc, list):
        return [untimed(v) for v in doc]
    return doc


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")


def plans(out: Path, assemblies: list[str], log) -> None:
    for name in assemblies:
        src = ROOT / "assemblies" / f"{name}.json"
        for variant, extra in VARIANTS.items():
            with tempfile.TemporaryDirectory() as tmp:
                status, stdout, stderr = run_cli(["plan", str(src), *COMMON, *extra,
                                                  "--out", str(Path(tmp) / "plan.json")])
                doc = json.loads((Path(tmp) / "plan.json").read_text())
                stdout, stderr = stdout.replace(tmp, "TMP"), stderr.replace(tmp, "TMP")
            text = "".join(line for line in stdout.splitlines(keepends=True)
                           if not line.startswith("time: "))
            _write(out / "plans" / name / f"{variant}.json",
                   json.dumps(untimed(doc), indent=2, sort_keys=True) + "\n")
            _write(out / "plans" / name / f"{variant}.txt",
                   f"exit {status}\n--- stdout\n{text}--- stderr\n{stderr}")
            log(f"{name:13s} {variant:15s} exit {status} R={doc.get('robustness')}")


def cli(out: Path) -> None:
    for command in ("plan", "experiment"):
        status, stdout, stderr = run_cli([command, "--help"])
        _write(out / "cli" / f"{command}-help.txt", f"exit {status}\n{stdout}{stderr}")
    lines = []
    src = str(ROOT / "assemblies" / "hexagon.json")
    with tempfile.TemporaryDirectory() as tmp:
        for args in BAD_PLANS:
            argv = ["plan", src, "--seed", "7", "--trials", "10", "--no-cache", "--workers", "1",
                    *args]
            if "--server" in args:
                argv = ["plan", src, *args]
            if args == ["--trust", "0.9"]:  # a warning, then a plan: keep only stderr
                argv += ["--method", "sim", "--out", str(Path(tmp) / "p.json")]
            status, _, stderr = run_cli(argv)
            stderr = re.sub(r"\s+", " ", stderr.replace(tmp, "TMP")).strip()
            lines.append(f"{' '.join(args)}\n  exit {status}: {stderr}\n")
    _write(out / "cli" / "plan-errors.txt", "".join(lines))


def experiment_names(out: Path) -> None:
    from rap.errors import InputError
    from rap.experiment.run import method_planner

    doc = {}
    for name in EXPERIMENT_NAMES:
        try:
            p = method_planner(name, 5)
        except Exception as exc:  # the kind a caller catches: InputError (exit 2) or another
            kind = "InputError" if isinstance(exc, InputError) else type(exc).__name__
            doc[name] = {"error": kind, "message": str(exc)}
        else:
            doc[name] = {"class": type(p).__name__, "name": p.name,
                         "attributes": {k: v for k, v in sorted(vars(p).items())}}
    _write(out / "experiment_names.json", json.dumps(doc, indent=2, default=repr) + "\n")


def api(out: Path) -> None:
    from rap.serve.api import BadRequest, parse_plan_request

    asm = json.loads((ROOT / "assemblies" / "hexagon.json").read_text())
    doc = []
    for method, options in API_REQUESTS:
        body = {"assembly": asm, "seed": 7, "options": options}
        if method is not None:
            body["method"] = method
        try:
            _, m, seed, opts, _cell = parse_plan_request(json.dumps(body).encode())
        except BadRequest as exc:
            answer = {"status": exc.status, "message": exc.message}
        else:
            answer = {"method": m, "seed": seed, "options": {k: [type(v).__name__, v]
                                                             for k, v in opts.items()}}
        doc.append({"method": method, "options": options, "answer": answer})
    _write(out / "api.json", json.dumps(doc, indent=2, default=repr) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path, help="Folder to write (emptied of earlier results).")
    ap.add_argument("--assembly", action="append", choices=ASSEMBLIES,
                    help="Only these reference assemblies (repeatable) [default: all six].")
    args = ap.parse_args()
    os.environ.setdefault("COLUMNS", "120")
    import rap

    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    for old in sorted(out.rglob("*"), reverse=True):
        old.unlink() if old.is_file() else old.rmdir()
    print(f"rap imported from {Path(rap.__file__).parent}", file=sys.stderr)
    cli(out)
    experiment_names(out)
    api(out)
    plans(out, args.assembly or ASSEMBLIES, lambda s: print(s, file=sys.stderr))
    print(f"wrote {out}; compare two commits' folders with diff -r", file=sys.stderr)


if __name__ == "__main__":
    main()

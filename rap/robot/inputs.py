"""The inputs of ``export`` and ``execute``: a plan document and the assembly it was made for.

A plan document (``rap-farm plan --out``) names its assembly (``"assembly"``) but does not carry
its geometry, which the grasps, the tray and the arm simulation need. ``load_plan_and_assembly``
takes the assembly file given (``--assembly``); without one it looks, in order, for
``NAME.json`` beside the plan file and for the assembly shipped with rap-farm under that name
(``rap/data/assemblies/``). Either way the assembly must hold every part the plan moves or fixes.

Every problem is one line (``InputError``, exit 2): a file that does not read, a document that is
not a found plan, an assembly that cannot be found or does not match. Cost: one JSON parse each.
"""

from __future__ import annotations

import json
from pathlib import Path

from rap.assembly import SHIPPED_ASSEMBLIES, Assembly
from rap.errors import InputError
from rap.plan.report.result import PlanResult

__all__ = ["load_plan", "plan_of", "check_assembly", "find_assembly", "load_plan_and_assembly"]


def load_plan(path: str | Path) -> tuple[PlanResult, dict]:
    """The found plan in ``path`` and its raw document. Raises ``InputError``."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"{path}: cannot read the plan ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a JSON plan document ({exc})") from None
    return plan_of(doc, str(path)), doc


def plan_of(doc, source: str) -> PlanResult:
    """The found plan of a parsed plan document; ``source`` names it in errors (a file, or the
    service's ``plan`` key). Raises ``InputError``."""
    if not isinstance(doc, dict):
        raise InputError(f"{source}: not a plan document (a JSON object from rap-farm plan --out)")
    try:
        plan = PlanResult.from_json(doc)
    except ValueError as exc:
        raise InputError(f"{source}: {exc}") from None
    if not plan.found:
        raise InputError(f"{source}: the plan found no sequence ("
                         f"{plan.message or plan.status.value}): nothing to build")
    return plan


def find_assembly(plan_path: str | Path, name: str) -> Path | None:
    """The assembly file a plan names when none is given (module doc), or None."""
    here = Path(plan_path).resolve().parent / f"{name}.json"
    shipped = SHIPPED_ASSEMBLIES / f"{name}.json"
    return next((p for p in (here, shipped) if p.is_file()), None)


def load_plan_and_assembly(plan_path: str | Path, assembly_path: str | Path | None
                           ) -> tuple[PlanResult, dict, Assembly]:
    """The plan, its document and its assembly (module doc). Raises ``InputError``."""
    from rap.io import load_assembly

    plan, doc = load_plan(plan_path)
    if assembly_path is None:
        assembly_path = find_assembly(plan_path, plan.assembly)
        if assembly_path is None:
            raise InputError(f"{plan_path}: the plan names assembly {plan.assembly!r} but does not "
                             f"carry its geometry, and no {plan.assembly}.json lies beside it: "
                             f"give the assembly file with --assembly")
    assembly = load_assembly(assembly_path)
    check_assembly(plan, assembly, f"--assembly {assembly_path}")
    return plan, doc, assembly


def check_assembly(plan: PlanResult, assembly: Assembly, source: str) -> None:
    """Raise ``InputError`` (naming ``source``) unless ``assembly`` holds every part the plan
    moves or fixes."""
    ids = set(assembly.ids)
    for k, s in enumerate(plan.steps, 1):
        missing = sorted(set(s.moving + s.fixed) - ids)
        if missing:
            raise InputError(f"{source}: has no part {missing[0]!r} of the plan's step {k}: not "
                             f"the plan's assembly")

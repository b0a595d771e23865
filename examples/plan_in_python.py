"""Plan an assembly from Python: import a drawing, plan it with the front door, read the plan.

    python examples/plan_in_python.py                              # examples/bracket.dxf
    python examples/plan_in_python.py examples/clip.svg --base base --out plan.json
    python examples/plan_in_python.py assemblies/hexagon.json

``rap.plan.plan(assembly, method="search", ...)`` is the one function the CLI, the planning
service and the experiment call; it returns a ``PlanResult`` (``rap.plan.report.result``) whose
``to_json()`` is the document ``rap-farm plan --out`` writes. The shipped model scores the
operations and the simulator checks the ones the search chooses: about 5 s for these drawings on
a 2-core machine. Run from the repository root (or with rap-farm installed).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from rap.cad.importer import ImportOptions, import_drawing
from rap.io import load_assembly
from rap.plan.cell.constraints import CellConstraints

EXAMPLES = Path(__file__).resolve().parent


def read(path: Path):
    """An exact assembly from a JSON file or a drawing. A drawing is flattened to 0.1 mm, as the
    tutorial's ``rap-farm import --tolerance 0.1`` does: fewer vertices, faster simulations."""
    if path.suffix.lower() in (".dxf", ".svg"):
        return import_drawing(path, ImportOptions(units="mm", tolerance="0.1")).assembly
    return load_assembly(path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("assembly", nargs="?", default=str(EXAMPLES / "bracket.dxf"))
    parser.add_argument("--method", default="search", help="search | rap | sim | optimal | random")
    parser.add_argument("--base", help="the part held in the fixture (with gravity -y)")
    parser.add_argument("--seed", type=int, default=0, help="the simulator's root seed")
    parser.add_argument("--out", type=Path, help="write the plan's JSON document here")
    args = parser.parse_args(argv)

    from rap.plan import plan  # the front door

    assembly = read(Path(args.assembly))
    # the robot cell: the base fixed, every intermediate assembly standing under gravity -y
    constraints = (CellConstraints.parse(base=args.base, gravity="0,-1")
                   if args.base else None)
    result = plan(assembly, args.method, constraints=constraints, seed=args.seed)

    if not result.found:  # infeasible: the message names the interlocked parts or the constraint
        print(f"{assembly.name}: no plan ({result.status.value}): {result.message}")
        return 1
    print(f"{assembly.name}: {len(result.steps)} steps, robustness R = {result.robustness:.3f}")
    for i, step in enumerate(result.steps, 1):
        dx, dy = step.insertion  # the direction the moving parts travel to their place
        print(f"  {i}. {','.join(step.moving)} into {','.join(step.fixed)} along "
              f"({dx:+.3f}, {dy:+.3f}): score {step.score:.2f}")
    if result.bound:  # search: an upper bound on the optimum's robustness
        print(f"  the optimum's robustness is at most {result.bound['robustness_upper']:.3f} "
              f"at {result.bound['confidence']:.0%} confidence")
    if args.out:
        args.out.write_text(json.dumps(result.to_json(), indent=1) + "\n")
        print(f"plan written to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

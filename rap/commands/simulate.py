"""``rap-farm simulate ASSEMBLY --moving A,B --direction DX,DY``: robustness score of one operation.

The moving subassembly (``--moving``, comma-separated part ids) travels along ``--direction`` (the
assembly direction, parsed exactly as decimals) to its place; the fixed subassembly is the rest of
the assembly. The operation must be feasible: no moving part may collide with a fixed part when
the moving set is removed along -direction (decided exactly on the NDBG); otherwise one line on
stderr and exit status 2. The simulator's rng is derived from ``--seed`` and the operation's content
key (``rap.seeds.derive_rng``), as the labelling farm does.

``--json`` prints exactly ``{"score": float, "successes": int, "trials": int, "seconds": float,
"params": {...}}``. ``--gif FILE`` writes an animated GIF of a few trials; ``--images FILE.png``
writes the start/goal image pair side by side.
"""

from __future__ import annotations

import json
from decimal import Decimal, InvalidOperation
from fractions import Fraction
from pathlib import Path

import typer

from rap.errors import InputError

__all__ = ["register", "parse_direction", "parse_moving", "build_operation"]


def parse_direction(text: str) -> tuple[Fraction, Fraction]:
    """``"DX,DY"`` -> exact (Fraction, Fraction); raises ``InputError`` on bad or zero input."""
    bits = [b.strip() for b in text.split(",")]
    if len(bits) != 2:
        raise InputError(f"--direction {text!r}: expected DX,DY (two numbers)")
    try:
        dx, dy = (Decimal(b) for b in bits)
    except InvalidOperation:
        raise InputError(f"--direction {text!r}: not numbers") from None
    if not (dx.is_finite() and dy.is_finite()):
        raise InputError(f"--direction {text!r}: not finite")
    if dx == 0 and dy == 0:
        raise InputError("--direction must not be the zero vector")
    return Fraction(dx), Fraction(dy)


def parse_moving(text: str, assembly) -> frozenset[str]:
    ids = [b.strip() for b in text.split(",") if b.strip()]
    if not ids:
        raise InputError("--moving: no part ids given")
    unknown = [i for i in ids if i not in assembly.ids]
    if unknown:
        raise InputError(f"--moving: no part {', '.join(map(repr, unknown))} in {assembly.name} "
                         f"(parts: {', '.join(assembly.ids)})")
    moving = frozenset(ids)
    if len(moving) == len(assembly.ids):
        raise InputError("--moving: every part is moving; leave at least one part fixed")
    return moving


def parse_fixed(text: str | None, assembly, moving: frozenset[str]) -> frozenset[str]:
    """The fixed subassembly: the given ids, or every part not moving."""
    if text is None:
        return frozenset(assembly.ids) - moving
    ids = frozenset(b.strip() for b in text.split(",") if b.strip())
    unknown = sorted(ids - set(assembly.ids))
    if unknown:
        raise InputError(f"--fixed: no part {', '.join(map(repr, unknown))} in {assembly.name}")
    if not ids:
        raise InputError("--fixed: no part ids given")
    if ids & moving:
        raise InputError(f"--fixed and --moving share {', '.join(sorted(ids & moving))}")
    return ids


def build_operation(assembly, moving: frozenset[str], direction: tuple[Fraction, Fraction],
                    fixed: frozenset[str] | None = None):
    """The ``Operation``; raises ``InputError`` when it is not feasible (exact NDBG test)."""
    from rap.operation import Operation, unit

    fixed = frozenset(assembly.ids) - moving if fixed is None else fixed
    try:
        from rap.geometry.ndbg import build_ndbg, is_feasible_operation
    except ImportError:  # geometry layer absent: no feasibility check possible
        is_feasible_operation = None
    if is_feasible_operation is not None:
        removal = (-direction[0], -direction[1])
        if not is_feasible_operation(build_ndbg(assembly), moving, fixed, removal):
            dx, dy = direction
            raise InputError(f"not a feasible operation: moving {{{','.join(sorted(moving))}}} "
                             f"along ({dx}, {dy}) collides with the fixed parts")
    return Operation(moving, fixed, unit(float(direction[0]), float(direction[1])), direction)


def register(app: typer.Typer) -> None:
    @app.command("simulate")
    def simulate_cmd(
        assembly_file: Path = typer.Argument(..., metavar="ASSEMBLY", help="Assembly JSON file."),
        moving: str = typer.Option(..., "--moving", help="Moving part ids, comma-separated."),
        fixed: str = typer.Option(None, "--fixed",
                                  help="Fixed part ids, comma-separated (default: every other "
                                       "part); parts in neither are left out."),
        direction: str = typer.Option(..., "--direction",
                                      help="Assembly direction DX,DY (the moving parts travel "
                                           "along it to their place)."),
        trials: int = typer.Option(100, "--trials", min=1, help="Noisy trials."),
        seed: int = typer.Option(None, "--seed", help="Root seed (default: rap.seeds default)."),
        eta: float = typer.Option(9.0, "--eta", min=0.0, help="Actuation noise factor."),
        as_json: bool = typer.Option(False, "--json", help="Print the result as JSON."),
        gif: Path = typer.Option(None, "--gif", help="Write an animated GIF of a few trials."),
        images: Path = typer.Option(None, "--images", help="Write the start/goal pair as PNG."),
    ):
        """Simulate one assembly operation with actuation noise and print its robustness score."""
        from rap.io import load_assembly
        from rap.seeds import DEFAULT_ROOT_SEED, derive_rng
        from rap.sim.params import SimParams
        from rap.sim.simulator import simulate

        asm = load_assembly(assembly_file)
        mov = parse_moving(moving, asm)
        op = build_operation(asm, mov, parse_direction(direction), parse_fixed(fixed, asm, mov))
        params = SimParams(trials=trials, eta=eta)
        root = DEFAULT_ROOT_SEED if seed is None else seed
        key = op.key(asm.geometry_hash, params.fingerprint())
        res = simulate(asm, op, params, derive_rng(root, key))
        if gif is not None:
            from rap.render.gif import write_trials_gif

            write_trials_gif(asm, op, gif, params, derive_rng(root, key))
        if images is not None:
            from rap.render.images import render_start_goal_png

            render_start_goal_png(asm, op, images, params)
        if as_json:
            typer.echo(json.dumps({"score": float(res.score), "successes": int(res.successes),
                                   "trials": int(res.trials), "seconds": float(res.seconds),
                                   "params": params.to_dict()}))
            return
        typer.echo(f"{asm.name}: {op.describe()}: score {res.score:.2f} "
                   f"({res.successes}/{res.trials} trials, {res.seconds:.2f} s, seed {root})")

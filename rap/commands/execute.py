"""``rap-farm execute PLAN.json [--cell C] [--assembly A] [--trials N] [--gif F] [--planar]``.

Runs a plan N times and reports what happened beside R (the plan's ``robustness`` and its
``robustness_interval``), the measured success with its 95% Clopper-Pearson interval:

* by default, on the cell's arm (``--arm`` replaces it: the Panda, a UR5e or UR10e) in pybullet
  (``rap.robot.arm_sim``): the program of
  ``rap-farm export`` (checked by the arm's kinematics first, exit 1 when unreachable), per step
  how often it was reached, inserted or jammed, and whether the arm touched a placed part;
  ``--gif FILE`` writes the first run as an animated GIF; each part sits off the cup's place by
  up to the cell's ``[errors] grasp_across_mm`` across the insertion (``--grasp-error-mm E``: a
  shorthand that replaces it);
* ``--planar``: rollouts in the planar simulator that scored the plan (``rap.execution``), each
  step starting where the earlier steps of the same rollout left the parts, each part off its
  place by a draw of the cell's error model (``[errors]``; ``--no-errors``: none); per step how
  often it was tried and failed, and its measured success (given the earlier steps succeeded)
  beside its score. Without ``--trials``, waves of rollouts until the 95% interval is within
  +-0.05. On this machine's worker processes (``--workers``), or on a Ray cluster's simulation
  pool with ``--address`` (the same figures: each rollout is seeded by its index).

One root seed (``--seed``) makes the runs reproducible. Exit status: 0 when the runs were made
(whatever their success); 1 a plan one arm cannot build or reach (arm mode); 2 bad input; 3 a
file that cannot be written. Cost: arm about 0.2-2 s a run (3 to 22 steps); planar about 4 n
operations' labelling per 100 rollouts of an n-step plan.
"""

from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["register", "execute_command"]


def _r_text(plan) -> str:
    if plan.robustness is None:
        return "R unknown (the plan carries no scores)"
    lo_hi = plan.robustness_interval
    iv = "" if lo_hi is None else f" [{lo_hi[0]:.3f}, {lo_hi[1]:.3f}]"
    return f"R = {plan.robustness:.3f}{iv}"


def execute_command(
    plan: Path = typer.Argument(..., metavar="PLAN.json", help="A plan from rap-farm plan --out."),
    cell: Path = typer.Option(None, "--cell", help="Robot cell TOML [default: the shipped cell]."),
    assembly: Path = typer.Option(None, "--assembly",
                                  help="The plan's assembly file [default: NAME.json beside the "
                                       "plan]."),
    trials: int = typer.Option(None, "--trials", min=1, max=100000,
                               help="Runs of the whole plan [default: arm 20; planar: until the "
                                    "95% interval is within +-0.05, at most 800]."),
    seed: int = typer.Option(0, "--seed", help="Root seed of the runs' noise."),
    gif: Path = typer.Option(None, "--gif", help="Write the first arm run as an animated GIF."),
    grasp_error_mm: float = typer.Option(None, "--grasp-error-mm", min=0.0, max=100.0,
                                         help="Each part sits off the cup's place by up to this "
                                              "across the insertion: a shorthand for the cell's "
                                              "[errors] grasp_across_mm [default: the cell's, "
                                              "0.5 mm]."),
    no_errors: bool = typer.Option(False, "--no-errors", help="Planar: no grasp or arm error, "
                                   "the carried noise alone."),
    address: str = typer.Option(None, "--address", help="Planar: run the rollouts on this Ray "
                                "cluster (HOST:PORT or auto; default $RAY_ADDRESS, else here)."),
    workers: int = typer.Option(None, "--workers", min=1, help="Planar: worker processes here, "
                                "or actors with --address [default: all CPUs]."),
    arm: str = typer.Option(None, "--arm", help="Arm: panda | ur5e | ur10e [default: the "
                                                "cell's [robot] arm]."),
    planar: bool = typer.Option(False, "--planar",
                                help="Run in the planar simulator, noise carried from step to "
                                     "step, instead of on the arm."),
) -> None:
    """Execute a plan N times (on the simulated arm, or --planar) and report its success beside R."""
    from rap.errors import InputError, StorageError
    from rap.robot.inputs import load_plan_and_assembly

    plan_r, _doc, asm = load_plan_and_assembly(plan, assembly)
    if planar:
        if gif is not None:
            raise InputError("--gif: pictures are of the arm; leave out --planar")
        _planar(plan_r, asm, cell, trials, seed, grasp_error_mm, address, workers, no_errors)
        return
    from dataclasses import replace

    from rap.robot.arm_sim import DEFAULT_ARM_SIM, run_arm
    from rap.robot.arms.export import check_arm
    from rap.robot.arms.registry import arm_spec
    from rap.robot.cell import load_cell, with_
    from rap.robot.program import build_program

    the_cell = load_cell(cell)
    if arm is not None:
        the_cell = with_(the_cell, "robot", arm=arm_spec(arm, "--arm").name)
    program = build_program(plan_r, asm, the_cell)
    report = check_arm(program)
    frames, shoot = None, None
    if gif is not None:
        from rap.robot.gif import camera

        frames, shoot = [], camera(program)
    from rap.commands._rollouts import cell_errors

    params = replace(DEFAULT_ARM_SIM, errors=cell_errors(the_cell, grasp_error_mm))
    out = run_arm(program, asm, trials=trials or 20, seed=seed, params=params, frames=frames,
                  camera=shoot)
    typer.echo(f"kinematic check: {len(program.waypoints)} waypoints reached by the "
               f"{program.cell.robot.arm} ({report.solves} points solved"
               f"{', IK branch ' + report.branch if report.branch else ''})")
    typer.echo("step  part            reached  inserted  jammed  arm touched a placed part, "
               "a placed part off its goal after the step")
    for s, c in zip(program.steps, out.steps):
        typer.echo(f"{s.index:>4}  {s.part[:14]:<14}  {c.reached:>7}  {c.inserted:>8}  "
                   f"{c.jammed:>6}  {c.arm_contacts:>3}  {c.displaced:>3}")
    typer.echo(f"arm success {out.success.text()} beside {_r_text(plan_r)}; {out.seconds:.1f} s")
    if gif is not None:
        from rap.robot.gif import write_gif

        try:
            write_gif(frames, gif)
        except OSError as exc:
            raise StorageError(f"--gif {gif}: cannot write ({exc.strerror or exc})") from None
        typer.echo(f"{gif}: {len(frames)} frames of the first run")


def register(app: typer.Typer) -> None:
    app.command("execute")(execute_command)


def _planar(plan_r, asm, cell, trials, seed, grasp_error_mm, address, workers,
            no_errors: bool = False) -> None:
    """``--planar``: rollouts under the cell's errors, here or on the farm's pool."""
    from rap.commands._progress import activity
    from rap.commands._rollouts import cell_errors, mm_per_unit, rollout_runner
    from rap.execution.error_model import ErrorModel
    from rap.robot.cell import load_cell
    from rap.robot.planar import run_planar

    the_cell = load_cell(cell)
    errors = ErrorModel.zero() if no_errors else cell_errors(the_cell, grasp_error_mm)
    with activity(f"rollouts of {plan_r.assembly}", None) as progress:
        def told(done, total):
            progress.update(f"rollouts: {done} of up to {total}")

        with rollout_runner(address, workers) as runner:
            out = run_planar(plan_r, asm, trials=trials, seed=seed, errors=errors,
                             mm_per_unit=mm_per_unit(the_cell, asm), runner=runner,
                             on_progress=told)
    typer.echo("step  moving          tried  failed  measured  score")
    for k, s in enumerate(plan_r.steps):
        tried, failed = out.step_tried[k], out.step_failed[k]
        measured = f"{1 - failed / tried:.3f}" if tried else "-"
        score = "-" if s.score is None else f"{s.score:.3f}"
        typer.echo(f"{k + 1:>4}  {','.join(s.moving)[:14]:<14}  {tried:>5}  {failed:>6}  "
                   f"{measured:>8}  {score:>5}")
    what = ", ".join(f"{k} {v:g}" for k, v in errors.to_dict().items())
    typer.echo(f"planar sequence success {out.success.text()} beside {_r_text(plan_r)}; "
               f"errors: {what}; {out.seconds:.1f} s")

"""Which inverse kinematics for ``rap.robot.kinematics``: reliability and speed on the Panda URDF.

Draws ``--targets`` tool-down targets (x 0.3-0.7 m, y -0.3-0.3 m, z 0.02-0.4 m, seed 0) and
solves each from the arm's home pose with (1) pybullet's ``calculateInverseKinematics`` iterated
with the joints clipped to their limits (``rap.robot.kinematics.IkSolver``, what rap uses),
(2) pybullet's null-space variant (the limits given to the solver, one call), and (3) ikpy on
the same URDF when ikpy is installed (it is not a dependency: ``pip install ikpy``). A target is
reached within 1 mm and 0.01 rad of tool-down with every joint inside its limits. Prints, per
method, the targets reached and the milliseconds a target (docs/ROBOT.md, "Why pybullet").

    python benchmarks/robot_ik_choice.py [--targets 200]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rap.robot.arm import ARM_MODELS, data_path, tcp_pose  # noqa: E402
from rap.robot.kinematics import IkSolver  # noqa: E402

DOWN = (1.0, 0.0, 0.0, 0.0)


def ok_pose(pos, orn, target, q, m) -> bool:
    ang = 2 * math.acos(min(1.0, abs(float(np.dot(orn, DOWN)))))
    inside = all(lo - 1e-6 <= v <= hi + 1e-6 for v, lo, hi in zip(q, m.lower, m.upper))
    return float(np.linalg.norm(np.array(pos) - target)) < 1e-3 and ang < 1e-2 and inside


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", type=int, default=200)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    targets = [np.array([rng.uniform(0.3, 0.7), rng.uniform(-0.3, 0.3), rng.uniform(0.02, 0.4)])
               for _ in range(args.targets)]
    m = ARM_MODELS["panda"]
    solver = IkSolver()
    w, arm = solver.world, solver.arm
    t0, hits = time.process_time(), 0
    for tg in targets:
        q, _, _, _ = solver.solve(tg, m.home)
        hits += ok_pose(*tcp_pose(w, arm, m, q), tg, q, m)
    print(f"pybullet, iterated and clipped: {hits}/{len(targets)} reached, "
          f"{(time.process_time() - t0) / len(targets) * 1e3:.2f} ms CPU a target")
    t0, hits = time.process_time(), 0
    ranges = [hi - lo for lo, hi in zip(m.lower, m.upper)]
    for tg in targets:
        for j, v in zip(m.joints, m.home):
            w.resetJointState(arm, j, v)
        q = w.calculateInverseKinematics(arm, m.tcp_link, list(tg), DOWN,
                                         lowerLimits=list(m.lower) + [0, 0],
                                         upperLimits=list(m.upper) + [0.04, 0.04],
                                         jointRanges=ranges + [0.04, 0.04],
                                         restPoses=list(m.home) + [0, 0],
                                         maxNumIterations=200, residualThreshold=1e-6)[:7]
        hits += ok_pose(*tcp_pose(w, arm, m, q), tg, q, m)
    print(f"pybullet, null-space variant:   {hits}/{len(targets)} reached, "
          f"{(time.process_time() - t0) / len(targets) * 1e3:.2f} ms CPU a target")
    solver.close()
    try:
        from ikpy.chain import Chain
    except ImportError:
        print("ikpy: not installed (pip install ikpy to compare)")
        return
    names = ["panda_link0"]
    for k in range(1, 8):
        names += [f"panda_joint{k}", f"panda_link{k}"]
    names += ["panda_joint8", "panda_link8", "panda_hand_joint", "panda_hand",
              "panda_grasptarget_hand", "panda_grasptarget"]
    urdf = f"{data_path()}/{m.urdf}"
    chain = Chain.from_urdf_file(urdf, base_elements=names)
    mask = [link.joint_type != "fixed" for link in chain.links]
    chain = Chain.from_urdf_file(urdf, base_elements=names, active_links_mask=mask)
    down = np.diag([1.0, -1.0, -1.0])
    sub = targets[:50]
    t0, hits = time.process_time(), 0
    for tg in sub:
        q = chain.inverse_kinematics(tg, down, orientation_mode="all")
        frame = chain.forward_kinematics(q)
        hits += (np.linalg.norm(frame[:3, 3] - tg) < 1e-3
                 and np.linalg.norm(frame[:3, :3] - down) < 1e-2)
    print(f"ikpy (first {len(sub)} targets):     {hits}/{len(sub)} reached, "
          f"{(time.process_time() - t0) / len(sub) * 1e3:.2f} ms CPU a target")


if __name__ == "__main__":
    import warnings

    warnings.filterwarnings("ignore")
    main()

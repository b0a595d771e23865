"""Universal Robots kinematics: forward from the registry's DH rows, inverse by ``ur-analytic-ik``.

``fk(dh, q)`` is the flange pose (4 x 4, the UR's base frame: the DH frame 0, which is the
controller's ``base``) of joint vectors ``q`` (shape ``(..., 6)``, batched, numpy), from the pinned
DH rows of ``rap.robot.arms.registry``; ``frames(dh, q)`` every joint frame on the way.
``ik(arm, pose)`` is every analytic solution (up to 8, each joint in [-pi, pi]) from
``ur_analytic_ik`` (C++ with Python bindings, Hawkins' closed form on UR's own DH values; the
tests check that its forward kinematics is ours to 1e-9 m at random joints).

**Branches.** The 8 solutions of a pose are the 2 x 2 x 2 choices of shoulder, elbow and wrist.
``branch_of(dh, q)`` names a solution's branch from geometry, so that it is the same for ``q``
and ``q + 2 pi k``: ``shoulder`` +1 when the wrist centre lies on the arm's front side (along
-x of frame 1, as at all joints 0), ``elbow`` +1 when the elbow lies above the line from the
shoulder to the wrist, ``wrist`` the sign of ``sin q5``. ``on_branch(arm, pose, branch, near)``
is the solution on ``branch`` nearest ``near`` among its ``2 pi`` turns within the joint limits.

**Singularities.** ``margins(dh, q)``: ``|sin q5|`` (wrist: axes 4 and 6 align at 0), ``|sin q3|``
(elbow: stretched or folded at 0), and the wrist centre's distance from the cylinder of radius
``d4`` about the base axis (shoulder: the two shoulder solutions meet there), in metres.

Cost: ``fk`` about 10 us a pose batched; ``ik`` about 60 us a pose (bindings' overhead).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rap.robot.arms.registry import DH, ArmSpec

__all__ = ["fk", "frames", "ik", "Branch", "branch_of", "branch_codes", "on_branch", "margins",
           "solutions", "BRANCHES", "tool_down_pose"]


def _dh_matrices(dh: DH, q: np.ndarray) -> list[np.ndarray]:
    """The 6 link transforms ``A_i(q_i)`` of a batch ``q`` (shape (..., 6)): (..., 4, 4) each."""
    out = []
    for i in range(6):
        th = q[..., i]
        ct, st = np.cos(th), np.sin(th)
        ca, sa = math.cos(dh.alpha[i]), math.sin(dh.alpha[i])
        A = np.zeros(q.shape[:-1] + (4, 4))
        A[..., 0, 0], A[..., 0, 1], A[..., 0, 2], A[..., 0, 3] = ct, -st * ca, st * sa, dh.a[i] * ct
        A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 3] = st, ct * ca, -ct * sa, dh.a[i] * st
        A[..., 2, 1], A[..., 2, 2], A[..., 2, 3] = sa, ca, dh.d[i]
        A[..., 3, 3] = 1.0
        out.append(A)
    return out


def frames(dh: DH, q) -> list[np.ndarray]:
    """The frames 1..6 (base to flange) at joints ``q`` (shape (..., 6)): 6 arrays (..., 4, 4)."""
    q = np.asarray(q, dtype=float)
    T = np.broadcast_to(np.eye(4), q.shape[:-1] + (4, 4))
    out = []
    for A in _dh_matrices(dh, q):
        T = T @ A
        out.append(T)
    return out


def fk(dh: DH, q) -> np.ndarray:
    """The flange's pose (..., 4, 4) in the base frame at joints ``q`` (shape (..., 6))."""
    return frames(dh, q)[-1]


def tool_down_pose(position, tool_offset_m: float = 0.0) -> np.ndarray:
    """The flange pose(s) (..., 4, 4) that put a TCP ``tool_offset_m`` along the flange's z at
    ``position`` (shape (..., 3)) with the tool pointing down (a half turn about the base's x:
    URScript's ``(pi, 0, 0)``)."""
    p = np.asarray(position, dtype=float)
    T = np.broadcast_to(np.diag([1.0, -1.0, -1.0, 1.0]), p.shape[:-1] + (4, 4)).copy()
    T[..., :3, 3] = p + [0.0, 0.0, tool_offset_m]
    return T


def ik(arm: ArmSpec, pose: np.ndarray) -> list[np.ndarray]:
    """Every analytic solution of the flange ``pose`` (4 x 4) on ``arm`` (module doc); [] when
    the pose is out of reach."""
    import ur_analytic_ik

    solver = getattr(ur_analytic_ik, arm.name)
    return solver.inverse_kinematics(np.ascontiguousarray(pose, dtype=float))


@dataclass(frozen=True)
class Branch:
    """One of the 8 IK branches (module doc): each of ``shoulder``, ``elbow``, ``wrist`` is +1
    or -1."""

    shoulder: int
    elbow: int
    wrist: int

    def __str__(self) -> str:
        return (f"shoulder {'front' if self.shoulder > 0 else 'back'}, elbow "
                f"{'up' if self.elbow > 0 else 'down'}, wrist {'+' if self.wrist > 0 else '-'}")


#: the branches in the order a program tries them (front, elbow up first)
BRANCHES = tuple(Branch(s, e, w) for s in (1, -1) for e in (1, -1) for w in (-1, 1))


def branch_codes(dh: DH, q) -> np.ndarray:
    """The branches of joint vectors ``q`` (shape (..., 6)) as an int array (..., 3) of
    (shoulder, elbow, wrist) signs (module doc); batched."""
    q = np.asarray(q, dtype=float)
    F = frames(dh, q)
    o1, o2, o3 = F[0][..., :3, 3], F[1][..., :3, 3], F[2][..., :3, 3]
    wc, x1 = F[4][..., :3, 3], F[0][..., :3, 0]
    shoulder = np.where(np.einsum("...i,...i", wc, x1) <= 0.0, 1, -1)
    v, w = o3 - o1, o2 - o1
    vv = np.maximum(np.einsum("...i,...i", v, v), 1e-300)
    off_z = w[..., 2] - np.einsum("...i,...i", w, v) / vv * v[..., 2]
    elbow = np.where(off_z >= 0.0, 1, -1)
    wrist = np.where(np.sin(q[..., 4]) >= 0.0, 1, -1)
    return np.stack([shoulder, elbow, wrist], axis=-1)


def branch_of(dh: DH, q) -> Branch:
    """The branch of one joint vector ``q`` (module doc)."""
    return Branch(*(int(v) for v in branch_codes(dh, q)))


def margins(dh: DH, q) -> np.ndarray:
    """``(|sin q5|, |sin q3|, shoulder distance m)`` of joint vectors ``q`` (shape (..., 6)):
    an array (..., 3) (module doc)."""
    q = np.asarray(q, dtype=float)
    wc = frames(dh, q)[4][..., :3, 3]
    return np.stack([np.abs(np.sin(q[..., 4])), np.abs(np.sin(q[..., 2])),
                     np.hypot(wc[..., 0], wc[..., 1]) - dh.d[3]], axis=-1)


def solutions(arm: ArmSpec, poses) -> np.ndarray:
    """Every analytic solution of each flange pose in ``poses`` (N x 4 x 4), on the 8 branches:
    an array (N, 8, 6) whose row ``b`` is the solution on ``BRANCHES[b]`` (NaN where there is
    none: out of reach). Cost: one ``ik`` a pose, the branches batched."""
    poses = np.asarray(poses, dtype=float)
    out = np.full((len(poses), len(BRANCHES), 6), np.nan)
    raw = [ik(arm, P) for P in poses]
    counts = np.array([len(r) for r in raw])
    if not counts.any():
        return out
    Q = np.array([s for r in raw for s in r], dtype=float)
    codes = branch_codes(arm.dh, Q)
    # BRANCHES' order: shoulder (1, -1), elbow (1, -1), wrist (-1, 1)
    b = (1 - codes[:, 0]) * 2 + (1 - codes[:, 1]) + (codes[:, 2] + 1) // 2
    out[np.repeat(np.arange(len(poses)), counts), b] = Q
    return out


def _nearest_turn(q: np.ndarray, near: np.ndarray, lower, upper) -> np.ndarray | None:
    """``q`` with each joint turned by a multiple of 2 pi to lie nearest ``near`` within
    [lower, upper]; None when some joint has no turn within its limits."""
    out = np.empty_like(q)
    for j in range(len(q)):
        k = round((near[j] - q[j]) / (2 * math.pi))
        best = None
        for kk in (k - 1, k, k + 1):
            v = q[j] + 2 * math.pi * kk
            if lower[j] <= v <= upper[j] and (best is None or abs(v - near[j]) < abs(best -
                                                                                   near[j])):
                best = v
        if best is None:
            return None
        out[j] = best
    return out


def on_branch(arm: ArmSpec, pose: np.ndarray, branch: Branch, near) -> np.ndarray | None:
    """The solution of ``pose`` on ``branch`` nearest ``near`` (module doc), or None when the
    pose is out of reach or the branch has no solution within the joint limits."""
    near = np.asarray(near, dtype=float)
    best, best_d = None, math.inf
    for sol in ik(arm, pose):
        sol = np.asarray(sol, dtype=float)
        if branch_of(arm.dh, sol) != branch:
            continue
        q = _nearest_turn(sol, near, arm.lower, arm.upper)
        if q is not None and (d := float(np.abs(q - near).max())) < best_d:
            best, best_d = q, d
    return best

"""The simulator's compiled control loop: numba code that drives Chipmunk through pymunk's C API;
and the scenes' polygons made through the same C API (``new_poly``).

One call of ``control_steps`` runs the proportional controller and the physics for every live trial
of one space, step after step, without returning to Python until a trial is decided (success or
hopeless failure), the noise block ends or the time runs out. Per control step it

1. reads every moving body's pose and velocity with pymunk's batched getter
   (``cpSpaceEachBody`` + ``pmSpaceBodyGetIteratorFuncBatched``, the C code behind
   ``pymunk.batch.get_space_bodies``) into a float buffer,
2. computes the path-frame errors, the outcome checks and the noisy command per trial (scalar
   float64 arithmetic in a fixed order: the same on every machine, unlike a BLAS matmul),
3. writes forces and torques with the batched setter and calls ``cpSpaceStep``
   ``control_substeps`` times.

The C functions are called through their addresses (taken from pymunk's cffi ``lib`` at run time
and passed in as integers), so the compiled code holds no process-specific constants and numba
can cache it on disk (``cache=True``). Nothing here allocates per step; there are no Python calls
inside the loop, so it also runs without the GIL.

Preconditions (kept by ``rap.sim.simulator``): the space holds exactly the moving bodies of the
trials as dynamic bodies (fixed shapes hang on ``space.static_body``, which the iterators do not
visit), sleeping is off, no Python collision callbacks are installed, and the float buffers are
large enough for every body (the getter never reallocates a buffer it does not own).

Cost: O(live trials) float operations per control step on top of Chipmunk's own step.
"""

from __future__ import annotations

import threading

import numpy as np
import numba
import pymunk
from pymunk._chipmunk import ffi as _ffi
from pymunk._chipmunk import lib as _cp
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__ = ["ChipmunkApi", "control_steps", "apply_and_step", "replay_steps", "DECIDED", "RAN_OUT",
           "CONSTANTS", "new_poly"]

DECIDED = 1  # a trial was decided at step c: commands for step c are in the set buffer, not applied
RAN_OUT = 0  # reached c_end

# indices into the float64 constants vector (see rap.sim.simulator.run_trials)
CONSTANTS = ("dx", "dy", "length", "mass", "moment", "tol2", "far2", "stuck_ctrl", "progress",
             "carrot_step", "lead", "eta", "kp", "kd", "amax2", "alpha_max", "ang_tol",
             "kp_angle", "kd_angle", "dt", "k_sub", "slow_check", "noise_chunk", "record_every",
             "start_x", "start_y")
(_DX, _DY, _L, _M, _I, _TOL2, _FAR2, _STUCK, _PROGRESS, _CARROT_STEP, _LEAD, _ETA, _KP, _KD,
 _AMAX2, _ALPHA_MAX, _ANG_TOL, _KP_ANG, _KD_ANG, _DT, _KSUB, _SLOW, _CHUNK, _REC_EVERY,
 _START_X, _START_Y) = range(len(CONSTANTS))

# indices into the uint64 pointer vector
_FN_STEP, _FN_EACH, _FN_GET, _FN_SET, _SPACE, _GET_DATA, _SET_DATA = range(7)

_I8P = ir.IntType(8).as_pointer()
_CALLBACK = ir.FunctionType(ir.VoidType(), [_I8P, _I8P]).as_pointer()


@intrinsic
def _call_step(typingctx, fn, space, dt):
    """``((void (*)(cpSpace *, cpFloat)) fn)(space, dt)``: cpSpaceStep through its address."""
    sig = types.void(types.uint64, types.uint64, types.float64)

    def codegen(context, builder, signature, args):
        f_addr, space_addr, dt_v = args
        fnty = ir.FunctionType(ir.VoidType(), [_I8P, ir.DoubleType()])
        f = builder.inttoptr(f_addr, fnty.as_pointer())
        builder.call(f, [builder.inttoptr(space_addr, _I8P), dt_v])
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def _call_each(typingctx, fn, space, func, data):
    """``cpSpaceEachBody(space, func, data)`` through its address."""
    sig = types.void(types.uint64, types.uint64, types.uint64, types.uint64)

    def codegen(context, builder, signature, args):
        f_addr, space_addr, func_addr, data_addr = args
        fnty = ir.FunctionType(ir.VoidType(), [_I8P, _CALLBACK, _I8P])
        f = builder.inttoptr(f_addr, fnty.as_pointer())
        builder.call(f, [builder.inttoptr(space_addr, _I8P), builder.inttoptr(func_addr, _CALLBACK),
                         builder.inttoptr(data_addr, _I8P)])
        return context.get_dummy_value()

    return sig, codegen


_LOCAL = threading.local()


def _buffers():
    """This thread's (get, set, ids) ``pymunk.batch.Buffer`` objects, made once and reused:
    pymunk never frees a Buffer's C arrays, so a Buffer per simulation would leak ~100 KB each."""
    bufs = getattr(_LOCAL, "buffers", None)
    if bufs is None:
        import pymunk.batch as pb

        bufs = _LOCAL.buffers = (pb.Buffer(), pb.Buffer(), pb.Buffer())
    return bufs


class ChipmunkApi:
    """Addresses of the C functions and batch buffers that the compiled loop uses for one space.

    ``get`` holds, after ``refresh_get``, a float64 view [bodies, 6] (x, y, angle, vx, vy, omega)
    of the getter's buffer (owned by pymunk's ``Buffer``); ``sarr`` [bodies, 3] (fx, fy, torque)
    is the setter's buffer (ours). ``gnum``/``snum`` are int32 views of the two arrays' ``num``
    counters, which the loop resets before each pass. The pymunk buffers are the thread's own
    (``_buffers``): one ``ChipmunkApi`` in use per thread at a time.
    """

    def __init__(self, space, bodies: int):
        import pymunk.batch as pb
        from pymunk._chipmunk import ffi, lib

        def addr(cdata) -> int:
            return int(ffi.cast("uintptr_t", cdata))

        self._ffi = ffi
        self._pb = pb
        self._space = space
        self.bodies = bodies
        fields_get = (pb.BodyFields.POSITION | pb.BodyFields.ANGLE | pb.BodyFields.VELOCITY
                      | pb.BodyFields.ANGULAR_VELOCITY)
        self._gbuf, self._sbuf, self._ibuf = _buffers()
        self._gbuf.clear()
        pb.get_space_bodies(space, fields_get, self._gbuf)  # grows pymunk's own array as needed
        self.sarr = np.zeros((bodies, 3))
        self._sbuf.set_float_buf(self.sarr)  # points the set array at ours (kept alive by it)
        self._gdata = ffi.new("pmBatchedData *")
        self._gdata.fields = fields_get.value
        self._gdata.floatArray = self._gbuf._float_arr
        self._gdata.intArray = self._gbuf._int_arr
        self._sdata = ffi.new("pmBatchedData *")
        self._sdata.fields = (pb.BodyFields.FORCE | pb.BodyFields.TORQUE).value
        self._sdata.floatArray = self._sbuf._float_arr
        self._sdata.intArray = self._sbuf._int_arr
        self.gnum = np.frombuffer(ffi.buffer(self._gbuf._float_arr, 16), dtype=np.int32)
        self.snum = np.frombuffer(ffi.buffer(self._sbuf._float_arr, 16), dtype=np.int32)
        self.ptrs = np.array([
            addr(ffi.addressof(lib, "cpSpaceStep")),
            addr(ffi.addressof(lib, "cpSpaceEachBody")),
            addr(ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched")),
            addr(ffi.addressof(lib, "pmSpaceBodySetIteratorFuncBatched")),
            addr(space._space), addr(self._gdata), addr(self._sdata)], dtype=np.uint64)
        self.refresh_get()

    def refresh_get(self) -> None:
        """Re-take the view of the getter's buffer (pymunk may have moved it while growing it)."""
        arr = self._gbuf._float_arr
        if arr.max < 6 * self.bodies:
            raise RuntimeError("pymunk batch buffer smaller than the space's bodies")
        self.get = np.frombuffer(self._ffi.buffer(arr.arr, 8 * 6 * self.bodies),
                                 dtype=np.float64).reshape(self.bodies, 6)

    def body_ids(self) -> np.ndarray:
        """Body ids in the iterators' order (after removals, Chipmunk swaps bodies around)."""
        pb = self._pb
        self._ibuf.clear()
        pb.get_space_bodies(self._space, pb.BodyFields.BODY_ID, self._ibuf)
        return np.frombuffer(self._ibuf.int_buf(), dtype=np.uintp).copy()


@numba.njit(cache=True, nogil=True)
def apply_and_step(ptrs, snum, k_sub, dt):
    """Apply the commands in the set buffer and step the space ``k_sub`` times."""
    for _ in range(k_sub):
        snum[0] = 0
        _call_each(ptrs[_FN_EACH], ptrs[_SPACE], ptrs[_FN_SET], ptrs[_SET_DATA])
        _call_step(ptrs[_FN_STEP], ptrs[_SPACE], dt)


@numba.njit(cache=True, nogil=True)
def replay_steps(ptrs, snum, sarr, log, c, c_end, k_sub, dt):
    """Apply logged commands ``log[c:c_end]`` and step: the Chipmunk floor of a control loop
    (the same set + step calls on the same states, with no controller)."""
    nb = sarr.shape[0]
    for t in range(c, c_end):
        for j in range(nb):
            sarr[j, 0] = log[t, j, 0]
            sarr[j, 1] = log[t, j, 1]
            sarr[j, 2] = log[t, j, 2]
        for _ in range(k_sub):
            snum[0] = 0
            _call_each(ptrs[_FN_EACH], ptrs[_SPACE], ptrs[_FN_SET], ptrs[_SET_DATA])
            _call_step(ptrs[_FN_STEP], ptrs[_SPACE], dt)


@numba.njit(cache=True, nogil=True)
def control_steps(ptrs, K, c, c_end, gnum, get, snum, sarr, ox, oy, carrot, best, last_improve,
                  live, rows, chunk, rec, decided, log):
    """Run control steps ``c, c + 1, ...`` until a trial is decided or ``c_end``.

    Per row j (the j-th moving body in the iterators' order; trial ``rows[j]``): ``ox, oy`` the
    world position of the trial's path start, ``carrot`` its carrot (arc length), ``best`` /
    ``last_improve`` its stuck bookkeeping, ``live`` 1 while undecided. ``chunk`` [noise_chunk,
    trials] holds the noise of the current block (step c uses row ``c % noise_chunk``). ``rec``
    [record, frames, 3] receives poses of trials < record every ``record_every`` steps (record 0:
    off). ``log`` [steps, bodies, 3], when not empty, receives the commands applied at each step
    (benchmarks replay them). On return ``decided[j]`` is 1 (success) / 2 (failure) for rows decided at the returned
    step, and (status, c, body_steps) says what happened: with DECIDED, the commands for step c
    are in ``sarr`` and not yet applied.
    """
    dx, dy = K[_DX], K[_DY]
    nx, ny = -dy, dx
    length = K[_L]
    mdx, mdy, mnx, mny = K[_M] * dx, K[_M] * dy, K[_M] * nx, K[_M] * ny
    inertia = K[_I]
    tol2, far2 = K[_TOL2], K[_FAR2]
    stuck = np.int64(K[_STUCK])
    progress = K[_PROGRESS]
    carrot_step, lead = K[_CARROT_STEP], K[_LEAD]
    eta = K[_ETA]
    kp, kd, amax2 = K[_KP], K[_KD], K[_AMAX2]
    alpha_max, ang_tol = K[_ALPHA_MAX], K[_ANG_TOL]
    kp_ang, kd_ang = K[_KP_ANG], K[_KD_ANG]
    dt = K[_DT]
    k_sub = np.int64(K[_KSUB])
    slow = np.int64(K[_SLOW])
    n_chunk = np.int64(K[_CHUNK])
    rec_every = np.int64(K[_REC_EVERY])
    start_x, start_y = K[_START_X], K[_START_Y]
    n_rec = rec.shape[0]
    pi = np.pi
    two_pi = 2.0 * np.pi
    na = rows.shape[0]
    body_steps = 0
    while c < c_end:
        gnum[0] = 0
        _call_each(ptrs[_FN_EACH], ptrs[_SPACE], ptrs[_FN_GET], ptrs[_GET_DATA])
        slow_step = c % slow == 0
        recording = n_rec > 0 and c % rec_every == 0
        any_decided = False
        for j in range(na):
            x = get[j, 0]
            y = get[j, 1]
            raw_angle = get[j, 2]
            vx = get[j, 3]
            vy = get[j, 4]
            omega = get[j, 5]
            rx = x - ox[j]
            ry = y - oy[j]
            s = rx * dx + ry * dy
            w = rx * nx + ry * ny
            ang = raw_angle
            if ang > pi or ang < -pi:  # wrap the orientation error to [-pi, pi)
                ang = (ang + pi) % two_pi - pi
            if recording:
                t = rows[j]
                if t < n_rec:
                    f = c // rec_every
                    rec[t, f, 0] = start_x + s * dx + w * nx
                    rec[t, f, 1] = start_y + s * dy + w * ny
                    rec[t, f, 2] = raw_angle
            e = s - length
            is_live = live[j] != 0
            succ = is_live and (e * e + w * w) < tol2 and abs(ang) < ang_tol
            fail = False
            if slow_step:
                beyond = max(max(-s, e), 0.0)
                fail = is_live and not succ and (w * w + beyond * beyond) > far2
                if stuck > 0:
                    dist = np.sqrt(e * e + w * w)
                    if dist < best[j] - progress:
                        best[j] = dist
                        last_improve[j] = c
                    if is_live and not succ and c - last_improve[j] > stuck:
                        fail = True
            # controller: a mass-normalised PD command toward the carrot, capped, plus noise
            cr = min(min(carrot[j] + carrot_step, s + lead), length)
            carrot[j] = cr
            a0 = -kp * s - kd * (vx * dx + vy * dy) + kp * cr
            a1 = -kp * w - kd * (vx * nx + vy * ny)
            a2 = a0 * a0 + a1 * a1
            if a2 > amax2:
                scale = np.sqrt(amax2 / a2)
                a0 *= scale
                a1 *= scale
            if eta > 0.0:  # + u |F| along the normal of F
                u = chunk[c % n_chunk, rows[j]]
                a0, a1 = a0 - u * a1, a1 + u * a0
            sarr[j, 0] = a0 * mdx + a1 * mnx
            sarr[j, 1] = a0 * mdy + a1 * mny
            alpha = -kp_ang * ang - kd_ang * omega
            sarr[j, 2] = min(max(alpha, -alpha_max), alpha_max) * inertia
            if succ:
                decided[j] = 1
                any_decided = True
            elif fail:
                decided[j] = 2
                any_decided = True
        if any_decided:
            return DECIDED, c, body_steps
        if log.shape[0] > 0:
            log[c, :, :] = sarr
        for _ in range(k_sub):
            snum[0] = 0
            _call_each(ptrs[_FN_EACH], ptrs[_SPACE], ptrs[_FN_SET], ptrs[_SET_DATA])
            _call_step(ptrs[_FN_STEP], ptrs[_SPACE], dt)
        body_steps += na * k_sub
        c += 1
    return RAN_OUT, c, body_steps


# -- polygons through the C API -----------------------------------------------------------------

_IDENTITY = tuple(pymunk.Transform.identity())  # what pymunk.Poly passes without a transform


def new_poly(body_ptr, vertices: list[tuple[float, float]], radius: float):
    """A Chipmunk polygon on the body ``body_ptr`` (a ``cpBody*``), made as ``pymunk.Poly`` makes
    one (the convex hull of ``vertices``, no transform; the same C calls, so the same scene bit for
    bit) but without its Python object: a scene holds a shape per piece per trial, and pymunk's
    bookkeeping per shape costs several times Chipmunk's own work. Added and removed with
    ``cpSpaceAddShape``/``cpSpaceRemoveShape``. The ``cpShape*`` is freed by pymunk's own rule
    when it is collected: taken out of its space if it is still in one, then freed. Any order of
    collection is safe: a ``pymunk.Space`` or ``pymunk.Body`` that goes first takes its shapes out
    of the space, and a space's static body lives inside its ``cpSpace`` (tests/sim,
    ``test_a_scene_dropped_in_any_order_frees_its_shapes_cleanly``)."""
    return _ffi.gc(_cp.cpPolyShapeNew(body_ptr, len(vertices), vertices, _IDENTITY, radius),
                   _free_shape)


def _free_shape(ptr) -> None:
    space = _cp.cpShapeGetSpace(ptr)
    if space != _ffi.NULL:
        _cp.cpSpaceRemoveShape(space, ptr)
    _cp.cpShapeFree(ptr)

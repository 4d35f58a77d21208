"""``derive.simulate(scene) -> Result``: validate once, choose a precompiled model, fill
its numbers, run the C runtime, and read the results back lazily.

The data flows once: the scene is parsed and validated (its law compiled into a program,
cached by its text), the model chosen, and what the C needs — options, parameters, the
law's arrays, the initial state — handed to a :class:`Session` of the model's library.
Extras (the general layout, omega, the height of S, K) are computed only when read.
"""
from __future__ import annotations

import ctypes
import threading
import time
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .. import abi, layout
from . import choice
from .build import DP, IP, Library, library
from .geometry import heights, kinetic_moment
from ..scene import Scene, load as _load

_S = abi.STATUS                 # return codes by name (abi.status_name: the reverse)
EVENT_KINDS = abi.names(abi.EVENT_KINDS)
MODES = abi.names(abi.MODES)
_COL = {name: k for k, name in enumerate(abi.EVENT_COLUMNS)}
# the friction columns of an event row, by the name Result.events gives them
_FRICTION_COLUMNS = ("P_X", "P_Y", "slip_X_minus", "slip_Y_minus", "slip_X_plus",
                     "slip_Y_plus", "work_normal", "work_friction")
STAT_NAMES = abi.names(abi.STATS)
SUMMARY_NAMES = abi.names(abi.SUMMARY)
ROW_KINDS = abi.names(abi.ROW_KINDS)
METHODS = {name: k for k, name in enumerate(abi.names(abi.METHODS))}


_O = abi.OPT


def options(scene: Scene, kind: str) -> np.ndarray:
    """The option vector of a run (indices from abi.OPTIONS)."""
    opt = [0.0] * len(abi.OPTIONS)
    opt[_O["method"]] = METHODS[scene.method]
    contact = scene.contact_possible
    opt[_O["plane"]] = 1.0 if contact else 0.0
    opt[_O["rtol"]], opt[_O["atol"]] = scene.rtol, scene.atol
    h_max = scene.duration / 4.0
    if contact:
        # the gap depends on the law directly, which the step control does not see:
        # at least about six steps per period of the point's motion
        h_max = min(h_max, scene.law_summary.time_scale)
    opt[_O["hmax"]] = h_max if scene.method != "rk4" else scene.step
    opt[_O["rk4_step"]] = scene.step
    opt[_O["max_steps"]] = scene.max_steps
    opt[_O["max_events"]] = scene.max_events
    opt[_O["output_dt"]] = scene.output_dt
    opt[_O["orthonormal"]] = 1.0 if scene.keep_orthonormal else 0.0
    opt[_O["time_scale"]] = scene.duration
    opt[_O["event_tol"]] = 1e-15
    opt[_O["length_scale"]] = choice.length_scale(scene) if contact else 0.0
    opt[_O["zeno_dt"]] = scene.zeno_dt
    return choice.vector(opt)          # (rows of them for a study's columns)


@dataclass
class Raw:
    """What one run of the C returns."""
    t: np.ndarray
    q: np.ndarray
    kinds: np.ndarray
    events: np.ndarray            # (K, 6): t, kind, value, v_n-, v_n+, t_accumulation
    stats: dict
    summary: dict
    status: str


class Session:
    """A run buffer over one model's library; reusable for many runs (a law, numbers and
    an initial state per run)."""

    def __init__(self, lib: Library, chunk: int = 8192):
        if chunk < max(abi.MIN_ROWS, abi.MIN_EVENTS):
            raise ValueError(f"Session: chunk = {chunk} rows, the runtime needs at least "
                             f"{max(abi.MIN_ROWS, abi.MIN_EVENTS)}")
        self.library = lib
        self._mem = ctypes.create_string_buffer(lib.session_size + 64)
        base = ctypes.addressof(self._mem)
        self.handle = ctypes.c_void_p((base + 63) // 64 * 64)
        self.chunk = chunk
        nq = lib.nq
        self.t_buf = np.zeros(chunk)
        self.q_buf = np.zeros((chunk, nq))
        self.k_buf = np.zeros(chunk, dtype=np.intc)
        self.ev_buf = np.zeros((chunk, len(abi.EVENT_COLUMNS)))
        self._out = (self.t_buf.ctypes.data_as(DP), self.q_buf.ctypes.data_as(DP),
                     self.k_buf.ctypes.data_as(IP), self.ev_buf.ctypes.data_as(DP))
        self._n, self._ne, self._init = ctypes.c_int(0), ctypes.c_int(0), ctypes.c_int(0)
        self._refs = (ctypes.byref(self._n), ctypes.byref(self._ne), ctypes.byref(self._init))
        self._law = None
        self._law_key = None
        # the inputs of crt_init and the counters, with their pointers made once
        self._opt = np.zeros(len(abi.OPTIONS))
        self._prm = np.zeros(len(abi.PARAMETERS))
        self._q0 = np.zeros(nq)
        self._stats = (ctypes.c_long * len(abi.STATS))()
        self._summ = np.zeros(len(abi.SUMMARY))
        self._in = (self._opt.ctypes.data_as(DP), self._prm.ctypes.data_as(DP),
                    self._q0.ctypes.data_as(DP), self._summ.ctypes.data_as(DP))

    def set_law(self, law) -> None:
        """Hand the law to the C (kept referenced here: the C reads these arrays)."""
        key = id(law)
        if key == self._law_key:
            return
        lib = self.library.lib
        arrays = law.arrays()
        if getattr(law, "kind", "") == "table":
            status = lib.crt_set_law_table(self.handle, len(arrays["knots"]),
                                           arrays["knots"].ctypes.data_as(DP),
                                           arrays["coef"].ctypes.data_as(DP),
                                           1 if law.periodic else 0)
        else:
            code = arrays["code"]
            status = lib.crt_set_law_program(self.handle, len(code), arrays["n_const"],
                                             code.ctypes.data_as(IP),
                                             arrays["consts"].ctypes.data_as(DP),
                                             len(arrays["consts"]),
                                             arrays["outputs"].ctypes.data_as(IP))
        if status != _S["ok"]:
            raise RuntimeError(f"the runtime refused the law ({abi.status_name(status)})")
        self._law, self._law_key = (law, arrays), key

    def law_at(self, t: float) -> np.ndarray:
        u = np.zeros(9)
        self.library.lib.crt_law_at(self.handle, float(t), u.ctypes.data_as(DP))
        return u

    def law_rows(self, t) -> np.ndarray:
        """(N, 9): u = (x, y, z, x', y', z', x'', y'', z'') at the times ``t``, by the C."""
        t = np.ascontiguousarray(t, dtype=float)
        u = np.zeros((len(t), 9))
        self.library.lib.crt_law_rows(self.handle, len(t), t.ctypes.data_as(DP),
                                      u.ctypes.data_as(DP))
        return u

    def _refused(self, status: int):
        """The error for crt_init's ``status`` (not ok), naming the option or parameter
        at fault (read from the C after that crt_init).  Validation should have refused
        the scene: say which rule the C applied."""
        from ..scene import SceneError
        lib, name = self.library.lib, abi.status_name(status)
        if status == _S["bad_options"]:
            k = lib.crt_bad_option(self.handle)
            what = (f"the option {abi.OPTIONS[k].name} = {self._opt[k]!r} (it must be "
                    f"{abi.OPTIONS[k].rule})") if 0 <= k < len(abi.OPTIONS) else "an option"
        elif status == _S["bad_parameters"]:
            k = lib.crt_bad_parameter(self.handle)
            what = (f"the parameter {abi.PARAMETERS[k].name} = {self._prm[k]!r} (it must "
                    f"be finite)") if 0 <= k < len(abi.PARAMETERS) else "a parameter"
        elif status == _S["bad_law"]:
            what = "the run: no law set"
        else:
            what = "the run's initial state"
        return SceneError("[run]", f"the runtime refused {what} ({name}); please report "
                                   "this scene")

    def init_status(self, opt, prm, t0: float, q0) -> int:
        """crt_init's return code for these inputs (the session is then set up when it is
        ok)."""
        self._opt[:] = opt
        self._prm[:] = prm
        self._q0[:] = q0
        op, pp, qp, _ = self._in
        return self.library.lib.crt_init(self.handle, op, pp, float(t0), qp)

    def init(self, opt, prm, t0: float, q0) -> None:
        status = self.init_status(opt, prm, t0, q0)
        if status != _S["ok"]:
            raise self._refused(status)

    def run(self, t0: float, duration: float, q0, opt, prm, progress=None,
            loop=None) -> Raw:
        """One run: a single crossing into C (crt_run) unless the buffers fill.  ``loop``:
        a :class:`derive.runtime.loop.Loop` closing the loop around the run (its log of
        the realised law is drained as the run goes)."""
        if loop is None:
            return self._run(t0, duration, q0, opt, prm, progress, None)
        loop.attach(self.library.lib, self.handle)
        try:
            return self._run(t0, duration, q0, opt, prm, progress, loop)
        finally:                              # the loop's memory is Python's: let go of it
            self.library.lib.crt_set_control(self.handle, None)
            # the session's law is now the controller's last (in that memory): the next
            # run sets its law again, even the same object (else it would run on that
            # stale law, and a loop closed then would start from it)
            self._law_key = None

    def _run(self, t0, duration, q0, opt, prm, progress, loop) -> Raw:
        lib = self.library.lib
        self._opt[:] = opt
        self._prm[:] = prm
        self._q0[:] = q0
        op, pp, q0p, summ = self._in
        tp, qp, kp, ep = self._out
        n_ref, ne_ref, init_ref = self._refs
        t_end = t0 + duration
        status = lib.crt_run(self.handle, op, pp, float(t0), q0p, t_end, tp, qp, kp,
                             self.chunk, n_ref, ep, self.chunk, ne_ref, self._stats, summ,
                             init_ref)
        if self._init.value != _S["ok"]:
            raise self._refused(self._init.value)
        n, ne = self._n.value, self._ne.value
        t, q, kinds, ev = (self.t_buf[:n].copy(), self.q_buf[:n].copy(),
                           self.k_buf[:n].copy(), self.ev_buf[:ne].copy())
        if status == _S["paused"]:            # a buffer filled: the rest chunk by chunk
            ts, qs, ks, evs = [t], [q], [kinds], [ev]
            while status == _S["paused"]:
                if progress is not None:
                    progress((lib.crt_time(self.handle) - t0) / duration)
                if loop is not None:
                    loop.drain(lib)
                status = lib.crt_advance(self.handle, t_end, tp, qp, kp, self.chunk,
                                         n_ref, ep, self.chunk, ne_ref)
                n, ne = self._n.value, self._ne.value
                ts.append(self.t_buf[:n].copy())
                qs.append(self.q_buf[:n].copy())
                ks.append(self.k_buf[:n].copy())
                evs.append(self.ev_buf[:ne].copy())
            lib.crt_stats(self.handle, self._stats)
            lib.crt_summary(self.handle, summ)
            t, q, kinds, ev = (np.concatenate(ts), np.concatenate(qs), np.concatenate(ks),
                               np.concatenate(evs))
        if status == _S["bad_argument"]:     # the buffers are checked in __init__
            raise RuntimeError(f"the runtime refused the buffers of {self.chunk} rows")
        if loop is not None:
            loop.drain(lib)
            if loop.error is not None:        # the Python controller raised: say so
                raise loop.error
            if status == _S["bad_control"]:
                raise ValueError(f"the controller's law was refused: {loop.fault(lib)}")
        if progress is not None:
            progress(1.0)
        return Raw(t, q, kinds, ev, dict(zip(STAT_NAMES, self._stats[:])),
                   dict(zip(SUMMARY_NAMES, self._summ.tolist())), abi.status_name(status))

    def run_in_contact(self, t0: float, duration: float, q0, opt, prm, mode: int,
                       direction=(1.0, 0.0)) -> Raw:
        """The rough model: a run that starts in contact (crt_set_contact_mode: ``mode``
        an index of abi.MODES, sliding along ``direction`` or sticking), its rows and
        events (the energy balance resamples short contact phases with it)."""
        lib = self.library.lib
        self.init(opt, prm, t0, q0)
        d = np.ascontiguousarray(direction, dtype=float)
        status = lib.crt_set_contact_mode(self.handle, int(mode), d.ctypes.data_as(DP))
        if status != _S["ok"]:
            raise ValueError(f"crt_set_contact_mode: {abi.status_name(status)}")
        tp, qp, kp, ep = self._out
        n_ref, ne_ref, _ = self._refs
        ts, qs, ks, evs = [], [], [], []
        status = _S["paused"]
        while status == _S["paused"]:
            status = lib.crt_advance(self.handle, t0 + duration, tp, qp, kp, self.chunk, n_ref,
                                     ep, self.chunk, ne_ref)
            n, ne = self._n.value, self._ne.value
            ts.append(self.t_buf[:n].copy())
            qs.append(self.q_buf[:n].copy())
            ks.append(self.k_buf[:n].copy())
            evs.append(self.ev_buf[:ne].copy())
        lib.crt_stats(self.handle, self._stats)
        lib.crt_summary(self.handle, self._in[3])
        return Raw(np.concatenate(ts), np.concatenate(qs), np.concatenate(ks),
                   np.concatenate(evs), dict(zip(STAT_NAMES, self._stats[:])),
                   dict(zip(SUMMARY_NAMES, self._summ.tolist())), abi.status_name(status))

    def run_many(self, t0, t_end, q0, opt, prm) -> dict:
        """Many runs of the session's law in one call into C (crt_run_many), keeping per
        run what a parameter study reads.  ``t0``, ``t_end``: (n,); ``q0``, ``opt``,
        ``prm``: (n, ...) rows.  Returns arrays: ``init_status``, ``status``, ``stats``
        (n, len(abi.STATS)), ``summary``, ``last`` (n, 1 + nq: t then q),
        ``first_contact`` (NaN where none) and the C's ``seconds`` for all of them."""
        n = len(t0)
        lib = self.library.lib
        arr = [np.ascontiguousarray(a, dtype=float) for a in (opt, prm, t0, q0, t_end)]
        shapes = [(n, len(abi.OPTIONS)), (n, len(abi.PARAMETERS)), (n,),
                  (n, self.library.nq), (n,)]
        if [a.shape for a in arr] != shapes:         # the C reads exactly these
            raise ValueError(f"run_many: shapes {[a.shape for a in arr]}, need {shapes}")
        out = {"init_status": np.zeros(n, dtype=np.intc), "status": np.zeros(n, dtype=np.intc),
               "stats": np.zeros((n, len(abi.STATS)), dtype=np.dtype(ctypes.c_long)),
               "summary": np.zeros((n, len(abi.SUMMARY))),
               "last": np.zeros((n, 1 + self.library.nq)), "first_contact": np.zeros(n)}
        tp, qp, kp, ep = self._out
        start = time.perf_counter()
        lib.crt_run_many(self.handle, n, *(a.ctypes.data_as(DP) for a in arr[:4]),
                         arr[4].ctypes.data_as(DP), tp, qp, kp, self.chunk, ep, self.chunk,
                         out["init_status"].ctypes.data_as(IP),
                         out["status"].ctypes.data_as(IP),
                         out["stats"].ctypes.data_as(ctypes.POINTER(ctypes.c_long)),
                         out["summary"].ctypes.data_as(DP), out["last"].ctypes.data_as(DP),
                         out["first_contact"].ctypes.data_as(DP))
        out["seconds"] = time.perf_counter() - start
        return out

    def contact(self, t: float, q) -> tuple[np.ndarray, float, float]:
        """(dq/dt, N, a_free) of persistent contact at (t, q) (after ``init``)."""
        q = np.ascontiguousarray(q, dtype=float)
        dq = np.zeros_like(q)
        N, a = ctypes.c_double(0.0), ctypes.c_double(0.0)
        self.library.lib.crt_eval_contact(self.handle, float(t), q.ctypes.data_as(DP),
                                          dq.ctypes.data_as(DP), ctypes.byref(N),
                                          ctypes.byref(a))
        return dq, N.value, a.value

    def gap(self, t: float, q) -> tuple[float, float]:
        """(h, v_n): the height of S above the plane and its rate at (t, q) (after
        ``init``)."""
        q = np.ascontiguousarray(q, dtype=float)
        h, v_n = ctypes.c_double(0.0), ctypes.c_double(0.0)
        self.library.lib.crt_eval_gap(self.handle, float(t), q.ctypes.data_as(DP),
                                      ctypes.byref(h), ctypes.byref(v_n))
        return h.value, v_n.value

    def contact_rows(self, t, Q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(dq/dt, N, a_free) of persistent contact along rows, in one call into C (after
        ``init``)."""
        t = np.ascontiguousarray(t, dtype=float)
        Q = np.ascontiguousarray(Q, dtype=float)
        dq, N, a = np.zeros_like(Q), np.zeros(len(t)), np.zeros(len(t))
        self.library.lib.crt_eval_contact_rows(self.handle, len(t), t.ctypes.data_as(DP),
                                               Q.ctypes.data_as(DP), dq.ctypes.data_as(DP),
                                               N.ctypes.data_as(DP), a.ctypes.data_as(DP))
        return dq, N, a

    def rough_rows(self, t, Q, modes, directions=None) -> tuple[np.ndarray, np.ndarray,
                                                                 np.ndarray]:
        """The rough model's contact along rows in the given modes (abi.MODES indices:
        sliding along ``directions`` (rows of 2; zero rows, or None: along the slip),
        sticking; any other mode: flight): (dq/dt, the reaction R at S in fixed axes, the
        velocity of S), in one call into C (after ``init``)."""
        t = np.ascontiguousarray(t, dtype=float)
        Q = np.ascontiguousarray(Q, dtype=float)
        modes = np.ascontiguousarray(modes, dtype=np.intc)
        n = len(t)
        d = np.zeros((n, 2)) if directions is None else \
            np.ascontiguousarray(directions, dtype=float)
        dq, R, v = np.zeros_like(Q), np.zeros((n, 3)), np.zeros((n, 3))
        self.library.lib.crt_eval_rough_rows(self.handle, n, t.ctypes.data_as(DP),
                                             Q.ctypes.data_as(DP), modes.ctypes.data_as(IP),
                                             d.ctypes.data_as(DP), dq.ctypes.data_as(DP),
                                             R.ctypes.data_as(DP), v.ctypes.data_as(DP))
        return dq, R, v

    def wrench_rows(self, t, Q, modes, directions, couples, couple_directions) -> tuple[
            np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`rough_rows` with spin friction or rolling resistance: ``couples``
        the held channels of each row (abi.COUPLE_BITS) and ``couple_directions`` rows of
        3 (the spin's sign, the rolling's direction; zero rows: along the angular
        velocity): (dq/dt, the wrench (R, T) at S, (v_S, A omega)), fixed axes."""
        t = np.ascontiguousarray(t, dtype=float)
        Q = np.ascontiguousarray(Q, dtype=float)
        modes = np.ascontiguousarray(modes, dtype=np.intc)
        couples = np.ascontiguousarray(couples, dtype=np.intc)
        d = np.ascontiguousarray(directions, dtype=float)
        cd = np.ascontiguousarray(couple_directions, dtype=float)
        n = len(t)
        dq, w, u = np.zeros_like(Q), np.zeros((n, 6)), np.zeros((n, 6))
        self.library.lib.crt_eval_wrench_rows(
            self.handle, n, t.ctypes.data_as(DP), Q.ctypes.data_as(DP),
            modes.ctypes.data_as(IP), d.ctypes.data_as(DP), couples.ctypes.data_as(IP),
            cd.ctypes.data_as(DP), dq.ctypes.data_as(DP), w.ctypes.data_as(DP),
            u.ctypes.data_as(DP))
        return dq, w, u

    def contact_wrench(self, t: float, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The rough model's contact as a wrench at (t, q): G (6x6), a_free and
        u = (v_S, A omega), fixed axes: du/dt = a_free + G (R, T) (after ``init``)."""
        q = np.ascontiguousarray(q, dtype=float)
        g21, a, u = np.zeros(21), np.zeros(6), np.zeros(6)
        self.library.lib.crt_eval_contact_wrench(self.handle, float(t), q.ctypes.data_as(DP),
                                                 g21.ctypes.data_as(DP), a.ctypes.data_as(DP),
                                                 u.ctypes.data_as(DP))
        G = np.zeros((6, 6))
        G[np.triu_indices(6)] = g21
        return G + np.triu(G, 1).T, a, u

    def delassus(self, t: float, q) -> tuple[np.ndarray, np.ndarray]:
        """The rough model's Delassus matrix W (3x3, fixed axes) and the velocity of S at
        (t, q) (after ``init``)."""
        q = np.ascontiguousarray(q, dtype=float)
        w6, v = np.zeros(6), np.zeros(3)
        self.library.lib.crt_eval_delassus(self.handle, float(t), q.ctypes.data_as(DP),
                                           w6.ctypes.data_as(DP), v.ctypes.data_as(DP))
        a, b, c, d, e, f = w6
        return np.array([[a, b, c], [b, d, e], [c, e, f]]), v

    def impact(self, W, v0) -> tuple[str, dict]:
        """The rough model's Darboux-Keller impact for a Delassus matrix W (3x3) and a
        velocity of S v0 with the session's parameters (after ``init``): its status and
        ``impulse`` (3), ``v_plus`` (3), ``work_normal``, ``work_friction``, ``stage``."""
        W = np.asarray(W, dtype=float)
        w6 = np.ascontiguousarray([W[0, 0], W[0, 1], W[0, 2], W[1, 1], W[1, 2], W[2, 2]])
        v0 = np.ascontiguousarray(v0, dtype=float)
        out = np.zeros(9)
        status = self.library.lib.crt_eval_impact(self.handle, w6.ctypes.data_as(DP),
                                                  v0.ctypes.data_as(DP),
                                                  out.ctypes.data_as(DP))
        return abi.status_name(status), {"impulse": out[:3], "v_plus": out[3:6],
                                         "work_normal": out[6], "work_friction": out[7],
                                         "stage": int(out[8])}

    def rhs_rows(self, t, Q) -> np.ndarray:
        """The flight right-hand side along rows (after ``init``)."""
        t = np.ascontiguousarray(t, dtype=float)
        Q = np.ascontiguousarray(Q, dtype=float)
        out = np.zeros_like(Q)
        self.library.lib.crt_eval_rhs_rows(self.handle, len(t), t.ctypes.data_as(DP),
                                           Q.ctypes.data_as(DP), out.ctypes.data_as(DP))
        return out


@dataclass
class Prepared:
    """A scene with everything its run needs (no SymPy, nothing compiled per scene)."""
    scene: Scene
    kind: str
    why: str
    start: choice.Start
    options: np.ndarray
    parameters: np.ndarray

    @property
    def library(self) -> Library:
        return library(self.kind)


def prepare(scene) -> Prepared:
    scene, static = _load(scene)
    kind, why = choice.choose(scene)
    st = choice.start(scene, kind)
    if static is None:
        return Prepared(scene, kind, why, st, options(scene, kind),
                        choice.parameters(scene, st.constants))
    # a Scene just made from a static part: what reads only its fields is kept there
    # (options: those fields and the RK4 step; parameters: those fields, when the model
    # adds no constants of the initial state); read-only, shared by the scenes
    memo = static.memo
    opt = memo.get(("options", scene.step))
    if opt is None:
        opt = _frozen(options(scene, kind))
        if len(memo) < 16:                   # (RK4's default step follows omega)
            memo[("options", scene.step)] = opt
    prm = memo.get("parameters") if not st.constants else None
    if prm is None:
        prm = _frozen(choice.parameters(scene, st.constants))
        if not st.constants:
            memo["parameters"] = prm
    return Prepared(scene, kind, why, st, opt, prm)


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


@dataclass
class Result:
    """The run of a scene.  ``t``, ``q`` (general layout when the pose is asked, else the
    model's own), ``state_names``, ``impacts`` (t, I, v_n-, v_n+), ``status``; the rest on
    demand: ``general``, ``omega``, ``height``, ``momentum``, ``extras``."""
    scene: Scene
    model: str
    why: str
    t: np.ndarray
    model_q: np.ndarray
    model_labels: tuple
    row_kind: np.ndarray
    event_rows: np.ndarray
    stats: dict
    summary: dict
    status: str
    start: choice.Start
    rates: np.ndarray | None = field(repr=False, default=None)   # dq/dt rows (planar, axisym.)
    timings: dict = field(default_factory=dict)

    @cached_property
    def session(self) -> Session:
        """A session of this run's model set up with its law, numbers and initial state,
        for evaluations after the run (the contact equations of the energy balance).  Its
        own: later runs of the thread's session do not change it."""
        s = Session(library(self.model), chunk=16)
        s.set_law(self.scene.law)
        s.init(options(self.scene, self.model),
               choice.parameters(self.scene, self.start.constants), self.scene.t0,
               self.start.q0)
        return s

    @cached_property
    def omega(self) -> np.ndarray:
        return choice.omega_of(self.scene, self.model, self.start, self.t, self.model_q,
                               self.rates)

    @cached_property
    def general(self) -> np.ndarray | None:
        return choice.to_general(self.scene, self.model, self.start, self.t, self.model_q,
                                 self.omega if self.model in ("planar", "axisymmetric")
                                 else None)

    @property
    def q(self) -> np.ndarray:
        return self.general if "pose" in self.scene.outputs and self.general is not None \
            else self.model_q

    @property
    def state_names(self) -> tuple:
        return choice.GENERAL_LABELS if "pose" in self.scene.outputs and \
            self.general is not None else self.model_labels

    @cached_property
    def height(self) -> np.ndarray | None:
        if not self.scene.size:
            return None
        zn = choice.vertical_of(self.model, self.general, self.model_q)
        if zn is None:
            return None
        return heights(self.scene, self.t, *zn)

    @cached_property
    def momentum(self) -> dict:
        """K about C in body axes (E1.4), |K|, and K in fixed axes when the attitude is
        known."""
        K = kinetic_moment(self.scene, self.omega, self.scene.law.jets(self.t))
        out = {"K_body": K, "K_norm": np.linalg.norm(K, axis=1)}
        if self.general is not None:
            A = self.general[:, layout.GENERAL.A].reshape(-1, 3, 3)
            out["K_fixed"] = np.einsum("nij,nj->ni", A, K)
        return out

    @property
    def extras(self) -> dict:
        wants = set(self.scene.outputs)
        out = {}
        if "omega" in wants:
            out["omega"] = self.omega
        if "height" in wants and self.height is not None:
            out["height"] = self.height
        if "momentum" in wants:
            out["momentum"] = self.momentum
        return out

    @property
    def rough(self) -> bool:
        """The run has Coulomb friction at S (the rough model)."""
        return self.model == "rough"

    @cached_property
    def events(self) -> list:
        """One dict per event: t, kind, value, v_minus, v_plus (t_accumulation for a
        contact).  The rough model adds ``mode`` (the contact mode after it: flight,
        sliding, sticking), and for impacts the tangential impulse P_X, P_Y, the slip of S
        before and after, the work of the normal impulse and of friction, and ``stage``
        (what happened inside: slip, stick, reslide); for stick, slip and reversal,
        v_minus and v_plus are the slip speed before and after and value the normal
        reaction (stick, reversal) or |R_t|/(mu_f R_Z) (slip)."""
        cols = abi.EVENT_COLUMNS
        contact = abi.index(abi.EVENT_KINDS, "contact")
        impact = abi.index(abi.EVENT_KINDS, "impact")
        out = []
        for r in self.event_rows:
            kind = int(r[1])
            ev = {"t": float(r[0]), "kind": EVENT_KINDS[kind], "value": float(r[2]),
                  "v_minus": float(r[3]), "v_plus": float(r[4]),
                  **({cols[5]: float(r[5])} if kind == contact else {})}
            if self.rough:
                ev["mode"] = MODES[int(r[_COL["mode"]])]
                if kind == impact:
                    ev.update({c: float(r[_COL[c]]) for c in _FRICTION_COLUMNS})
                    ev["stage"] = ("slip", "stick", "reslide")[int(r[_COL["stage"]])]
                if self.couples_on:
                    ev["couples"] = int(r[_COL["couples"]])
            out.append(ev)
        return out

    @property
    def couples_on(self) -> bool:
        """The rough model with spin friction or rolling resistance."""
        return self.rough and (self.scene.spin_friction > 0.0
                               or self.scene.rolling_resistance > 0.0)

    @cached_property
    def couples(self) -> np.ndarray:
        """The couples' channels held on every row (bits abi.COUPLE_BITS: 1 the spin, 2 the
        rolling; 0 in flight and without couples), from the events as :attr:`modes`."""
        from .motion import contact_couples
        return contact_couples(self)

    @cached_property
    def modes(self) -> np.ndarray:
        """The contact mode of every row (indices into abi.MODES: 0 flight, 1 smooth
        contact, 2 sliding, 3 sticking), from the events (motion.contact_modes)."""
        from .motion import contact_modes
        return contact_modes(self)

    @cached_property
    def slip(self) -> np.ndarray | None:
        """The rough model: the slip velocity of S (v_X, v_Y, fixed axes) on every row,
        from the runtime's general_contact_velocity; None for the other models."""
        if not self.rough:
            return None
        _, _, v = self.session.rough_rows(self.t, self.model_q, np.zeros(len(self.t)))
        return v[:, :2]

    IMPACT_FRICTION_COLUMNS = ("P_X", "P_Y", "slip_X_minus", "slip_Y_minus", "slip_X_plus",
                               "slip_Y_plus", "work_normal", "work_friction", "stage")

    @cached_property
    def impacts_friction(self) -> np.ndarray:
        """The rough model: per impact the columns of ``IMPACT_FRICTION_COLUMNS`` (stage: 0
        slip to the end, 1 stick, 2 re-slide); (0, 9) otherwise."""
        rows = self.event_rows
        if not self.rough or not len(rows):
            return np.zeros((0, len(self.IMPACT_FRICTION_COLUMNS)))
        sel = rows[:, 1] == abi.index(abi.EVENT_KINDS, "impact")
        return rows[sel][:, [_COL[c] for c in self.IMPACT_FRICTION_COLUMNS]]

    @cached_property
    def impacts(self) -> np.ndarray:
        rows = self.event_rows
        sel = rows[:, 1] == abi.index(abi.EVENT_KINDS, "impact") if len(rows) else []
        return rows[sel][:, [0, 2, 3, 4]] if len(rows) else np.zeros((0, 4))

    @property
    def min_height(self) -> float:
        return self.summary["min_height"]

    @property
    def min_normal(self) -> float:
        return self.summary["min_normal"]


_LOCAL = threading.local()


def session_for(kind: str) -> Session:
    """This thread's session of a model (buffers allocated once, reused by every run of
    the thread; threads never share one)."""
    sessions = getattr(_LOCAL, "sessions", None)
    if sessions is None:
        sessions = _LOCAL.sessions = {}
    if kind not in sessions:
        sessions[kind] = Session(library(kind))
    return sessions[kind]


def run_prepared(prep: Prepared, session: Session | None = None, progress=None,
                 loop=None) -> Result:
    """Run a prepared scene (``loop``: closed around the run, see derive.runtime.loop)."""
    timings = {}
    start = time.perf_counter()
    session = session or session_for(prep.kind)
    timings["load_s"] = time.perf_counter() - start
    start = time.perf_counter()
    session.set_law(prep.scene.law)
    raw = session.run(prep.scene.t0, prep.scene.duration, prep.start.q0, prep.options,
                      prep.parameters, progress, loop=loop)
    rates = session.rhs_rows(raw.t, raw.q) if prep.kind in ("planar", "axisymmetric") \
        else None
    timings["run_s"] = time.perf_counter() - start
    return Result(scene=prep.scene, model=prep.kind, why=prep.why, t=raw.t, model_q=raw.q,
                  model_labels=session.library.labels, row_kind=raw.kinds,
                  event_rows=raw.events, stats=raw.stats, summary=raw.summary,
                  status=raw.status, start=prep.start, rates=rates, timings=timings)


def simulate(scene, progress: bool = False) -> Result:
    """Simulate a scene (a path, a dict of the schema, or a :class:`Scene`); see the
    README.  ``progress``: a bar on stderr for runs longer than a second."""
    start = time.perf_counter()
    prep = prepare(scene)
    t_prepare = time.perf_counter() - start
    bar = None
    if progress:
        from ..progress import Bar
        bar = Bar("simulating")
    result = run_prepared(prep, progress=bar.update if bar else None)
    if bar:
        bar.close()
    result.timings = {"prepare_s": t_prepare, **result.timings,
                      "library_build_s": prep.library.build_seconds}
    return result

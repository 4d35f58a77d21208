"""A session over one compiled model: the ctypes calls into the C runtime.

:class:`Session` holds a run's buffers and the model's library (:mod:`derive.runtime.build`)
and makes every call into C: a law handed over (``set_law``), ``crt_init``, a run
(``run``: one ``crt_run`` unless a buffer fills, then ``crt_advance`` chunk by chunk), a
run that starts in contact, many runs in one call (``run_many``) and the evaluations of
the model's functions along rows (contact, gap, the rough contact, the wrench, the
Delassus matrix, an impact, the flight right-hand side).  It knows no scene: options,
parameters and the initial state come as vectors indexed by :mod:`derive.abi`
(:func:`derive.runtime.driver.options` and :func:`derive.runtime.choice.parameters` fill
them), and what it returns is :class:`Raw` arrays, which :mod:`derive.runtime.driver`
wraps in a :class:`~derive.runtime.driver.Result`.  :func:`session_for` gives each thread
its own session of a model.
"""
from __future__ import annotations

import ctypes
import threading
import time
from dataclasses import dataclass

import numpy as np

from .. import abi
from ..scene.errors import SceneError
from .build import DP, IP, Library, library

_S = abi.STATUS                 # return codes by name (abi.status_name: the reverse)
STAT_NAMES = abi.names(abi.STATS)
SUMMARY_NAMES = abi.names(abi.SUMMARY)


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
        if getattr(law, "kind", "") == "bodies":         # several bodies: crt_law_rows
            a = arrays
            status = lib.crt_set_law_bodies(
                self.handle, a["n_points"], a["n_rotors"], a["out"].ctypes.data_as(IP),
                a["n_nodes"], a["n_const"], a["code"].ctypes.data_as(IP),
                a["consts"].ctypes.data_as(DP), len(a["consts"]), a["n_knots"],
                a["n_columns"], a["knots"].ctypes.data_as(DP), a["coef"].ctypes.data_as(DP),
                a["periodic"])
        elif getattr(law, "kind", "") == "table":
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
        u = np.zeros(self.library.lib.crt_law_width(self.handle))
        self.library.lib.crt_law_at(self.handle, float(t), u.ctypes.data_as(DP))
        return u

    def law_rows(self, t) -> np.ndarray:
        """(N, width): u at the times ``t``, by the C; one point's u = (x, y, z, x', y',
        z', x'', y'', z''), several bodies' in the order of derive.layout.law_width."""
        t = np.ascontiguousarray(t, dtype=float)
        u = np.zeros((len(t), self.library.lib.crt_law_width(self.handle)))
        self.library.lib.crt_law_rows(self.handle, len(t), t.ctypes.data_as(DP),
                                      u.ctypes.data_as(DP))
        return u

    def _refused(self, status: int):
        """The error for crt_init's ``status`` (not ok), naming the option or parameter
        at fault (read from the C after that crt_init).  Validation should have refused
        the scene: say which rule the C applied."""
        lib, name = self.library.lib, abi.status_name(status)
        if status == _S["bad_options"]:
            k = lib.crt_bad_option(self.handle)
            what = (f"the option {abi.OPTIONS[k].name} = {self._opt[k]!r} (it must be "
                    f"{abi.OPTIONS[k].rule})") if 0 <= k < len(abi.OPTIONS) else "an option"
        elif status == _S["bad_parameters"]:
            k = lib.crt_bad_parameter(self.handle)
            name = abi.PARAMETERS[k].name if 0 <= k < len(abi.PARAMETERS) else ""
            rule = (abi.BODIES_RULE if name in abi.BODY_PARAMETERS and self.library.moments
                    else "be finite")
            what = (f"the parameter {name} = {self._prm[k]!r} (it must {rule})"
                    if name else "a parameter")
        elif status == _S["bad_law"]:
            what = ("the run: no law set (or a law of several bodies in a model of one "
                    "point: only the moments models read one)")
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

    def noise(self, t: float, q) -> tuple[float, float]:
        """(height resolution, speed noise): the height and the normal speed below which
        the runtime's event search calls them round-off at (t, q) (crt_plane.h's
        crt_height_resolution and crt_speed_noise, after ``init``; 0, 0 without a plane)."""
        q = np.ascontiguousarray(q, dtype=float)
        out = np.zeros(2)
        self.library.lib.crt_eval_noise(self.handle, float(t), q.ctypes.data_as(DP),
                                        out.ctypes.data_as(DP))
        return float(out[0]), float(out[1])

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

    def slip_band(self, t: float, q) -> dict:
        """The slip's speeds a contact mode entered at (t, q) sets (after ``init``):
        ``scale``, ``eps`` (round-off), ``arm`` (resolved) and ``freeze`` (below it a
        sliding friction keeps the direction the slip had at its step's start)."""
        q = np.ascontiguousarray(q, dtype=float)
        band = np.zeros(4)
        self.library.lib.crt_eval_slip_band(self.handle, float(t), q.ctypes.data_as(DP),
                                            band.ctypes.data_as(DP))
        return dict(zip(("scale", "eps", "arm", "freeze"), band.tolist()))

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

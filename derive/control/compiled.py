"""The C controller compiled and loaded (:class:`Compiled`): the sources of
:mod:`derive.control.render` with the timing shim (``templates/control/ctl_timing.c``),
built by :func:`derive.cbuild.build_shared` (cached by hash) and called through ctypes.
"""
from __future__ import annotations

import ctypes

import numpy as np

from ..runtime.loop import Segments

# controller.h's CTL_STAT_* in order (the C's CTL_NSTATS: checked when loaded)
STATS = ("calls", "replans", "failures", "softened", "last_status", "last_iterations")


class Compiled:
    """The controller compiled with the timing shim and loaded: ``controller()`` gives a
    :class:`~derive.runtime.loop.CController` for a run (its memory initialised), and
    ``times()`` the solve time of every call that ran the solver since."""

    def __init__(self, sources: dict, flags: tuple | None = None):
        from ..cbuild import build_shared, runtime_flags
        from ..paths import c_sources
        files = dict(sources)
        files["ctl_timing.c"] = (c_sources("control") / "ctl_timing.c").read_text(
            encoding="utf-8")
        self.path = build_shared(files, flags=flags or runtime_flags(), name="controller")
        lib = ctypes.CDLL(str(self.path))
        for name in ("ctl_sizeof", "ctl_timed_sizeof"):
            getattr(lib, name).restype = ctypes.c_int
        lib.ctl_init.argtypes = [ctypes.c_void_p]
        lib.ctl_stats.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_long)]
        self.lib = lib
        self.mem = ctypes.create_string_buffer(lib.ctl_sizeof() + 64)
        self.inner = ctypes.c_void_p((ctypes.addressof(self.mem) + 63) // 64 * 64)
        lib.ctl_log_columns.restype = ctypes.c_int
        self.log = np.zeros((4096, lib.ctl_log_columns()))

        DP = ctypes.POINTER(ctypes.c_double)

        class Timed(ctypes.Structure):
            _fields_ = [("inner", ctypes.c_void_p), ("log", DP), ("cap", ctypes.c_int),
                        ("n", ctypes.c_int), ("laws", DP), ("laws_cap", ctypes.c_int),
                        ("laws_n", ctypes.c_int)]
        if ctypes.sizeof(Timed) != lib.ctl_timed_sizeof():
            raise RuntimeError("ctl_timed: the layouts differ")
        if lib.ctl_timed_nstats() != len(STATS):
            raise RuntimeError("ctl_stats: the counters differ from controller.h's")
        lib.ctl_law_row.restype = ctypes.c_int
        self.law_log = np.zeros((512, lib.ctl_law_row()))
        self.timed = Timed(self.inner, self.log.ctypes.data_as(DP), len(self.log), 0,
                           self.law_log.ctypes.data_as(DP), len(self.law_log), 0)
        self.address = ctypes.cast(lib.ctl_timed_controller, ctypes.c_void_p).value
        self.raw_address = ctypes.cast(lib.ctl_controller, ctypes.c_void_p).value

    def controller(self, timed: bool = True):
        """A fresh run's controller (its memory initialised, the log emptied)."""
        from ..runtime.loop import CController
        self.lib.ctl_init(self.inner)
        self.timed.n = 0
        self.timed.laws_n = 0
        if timed:
            return CController(self.address, ctypes.pointer(self.timed), keep=(self,))
        return CController(self.raw_address, self.inner, keep=(self,))

    def call(self, controller, call):
        """Call the compiled controller (its raw function, ``controller`` from
        ``controller(timed=False)``) on a :class:`~derive.runtime.loop.Call` from Python:
        the law it returns (Segments) or None (for checks against the Python route)."""
        from ..runtime.loop import (CONTROLLER_FN, MAX_KNOTS, REASONS, CallStruct)
        DP = ctypes.POINTER(ctypes.c_double)
        q = np.ascontiguousarray(call.q, dtype=float)
        u = np.ascontiguousarray(call.u, dtype=float)
        cs = CallStruct(call.t, REASONS.index(call.reason), 0, len(q), q.ctypes.data_as(DP),
                        u.ctypes.data_as(DP), call.k)
        knots, coef = np.zeros(MAX_KNOTS), np.zeros((MAX_KNOTS - 1) * 12)
        n = ctypes.c_int(0)
        fn = CONTROLLER_FN(self.raw_address)
        r = fn(controller.ctx, ctypes.byref(cs), MAX_KNOTS, ctypes.byref(n),
               knots.ctypes.data_as(DP), coef.ctypes.data_as(DP))
        if r != 1:
            return None
        k = n.value
        return Segments(knots[:k].copy(), coef[:(k - 1) * 12].reshape(k - 1, 3, 4).copy())

    def times(self) -> np.ndarray:
        """(t, seconds) of the calls that ran the solver in the last run."""
        return self.log[:self.timed.n, :2].copy()

    def solves(self) -> dict:
        """The calls that ran the solver in the last run, column by column: t, seconds,
        failed (the law in use went on), softened, the QP's iterations."""
        rows = self.log[:self.timed.n]
        return {"t": rows[:, 0].copy(), "seconds": rows[:, 1].copy(),
                "failed": rows[:, 2] > 0, "softened": rows[:, 3] > 0,
                "qp_iterations": rows[:, 4].astype(int)}

    def laws(self) -> list:
        """(t, Segments) of every law the controller set in the last run (timed)."""
        out = []
        k = self.law_log.shape[1]
        n_max = (k - 2) // 13 + 1                    # CTL_KNOTS: k = n + 2 + (n - 1) 12
        for row in self.law_log[:self.timed.laws_n]:
            n = int(row[1])
            out.append((float(row[0]), Segments(row[2:2 + n].copy(), row[2 + n_max:2 + n_max
                        + (n - 1) * 12].reshape(n - 1, 3, 4).copy())))
        return out

    def stats(self) -> dict:
        """The counters (controller.h's CTL_STAT_*, by name)."""
        out = (ctypes.c_long * len(STATS))()
        self.lib.ctl_stats(self.inner, out)
        return dict(zip(STATS, out[:]))

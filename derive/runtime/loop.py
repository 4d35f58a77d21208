"""The closed loop at run time: the binding of ``crt_control.h``.

A :class:`Loop` holds what closes the loop around one run: the controller, the sample
period, the noise on what the controller reads and its seed, and the pushes.  The
controller is either

* a Python callable (research): ``controller(call) -> None | Segments | STOP`` with
  ``call`` a :class:`Call` (the time, why, the measured state in the model's layout, the
  law's u at that time): None lets the law go on, :data:`STOP` ends the run (status
  ``stopped``); the C calls it through ctypes at every sample and event; or
* a C function of the ABI ``crt_controller_fn`` in a compiled library, with its own
  memory (:class:`CController`): the C runtime calls it with no Python per sample.

Either writes the law from the call's time on as cubic segments (:class:`Segments`, the
layout of ``crt_set_law_table``) whose x and x' continue the law's at that time.  The
runtime logs the law it ran (:func:`realised_law` turns the log into a table law that
replays the run).  Nothing here is a scene: the plant's numbers (a heavier body, another
restitution) are the scene's; :mod:`derive.control` builds both.
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass, field

import numpy as np

from .. import abi
from ..scene.table import TableLaw
from .build import DP

MAX_KNOTS = abi.CTL_MAX_KNOTS
STOP = "stop"             # what a Python controller returns to end the run
LOG_ROWS = 8 * MAX_KNOTS
_S = abi.STATUS


class CallStruct(ctypes.Structure):
    """``crt_call`` (crt_control.h)."""
    _fields_ = [("t", ctypes.c_double), ("reason", ctypes.c_int), ("event", ctypes.c_int),
                ("nq", ctypes.c_int), ("q", ctypes.POINTER(ctypes.c_double)),
                ("u", ctypes.POINTER(ctypes.c_double)), ("k", ctypes.c_long)]


CONTROLLER_FN = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.POINTER(CallStruct),
                                 ctypes.c_int, ctypes.POINTER(ctypes.c_int), DP, DP)
REASONS = abi.names(abi.CALL_REASONS)
EVENTS = abi.names(abi.EVENT_KINDS)


@dataclass(frozen=True)
class Call:
    """One call of a controller: ``q`` the measured state (the model's layout), ``u`` the
    law's x, y, z, x', y', z', x'', y'', z'' at ``t``."""
    t: float
    reason: str                 # start | sample | event
    event: str                  # the event's kind for reason = event (impact, ...)
    q: np.ndarray
    u: np.ndarray
    k: int                      # the calls before this one


@dataclass
class Segments:
    """A law from its first knot on: ``knots`` (n,) increasing, ``coef`` (n - 1, 3, 4),
    the cubic of x, y, z on each interval (c0 s^3 + c1 s^2 + c2 s + c3, s = t - knot)."""
    knots: np.ndarray
    coef: np.ndarray

    def at(self, t: float) -> np.ndarray:
        """u = (x, y, z, x', y', z', x'', y'', z'') at t (the last cubic beyond the end)."""
        i = int(np.clip(np.searchsorted(self.knots, t, side="right") - 1, 0,
                        len(self.knots) - 2))
        s = t - self.knots[i]
        c0, c1, c2, c3 = (self.coef[i, :, k] for k in range(4))
        return np.concatenate([((c0 * s + c1) * s + c2) * s + c3,
                               (3 * c0 * s + 2 * c1) * s + c2, 6 * c0 * s + 2 * c1])


def hermite(t0: float, x0, v0, t1: float, x1, v1) -> np.ndarray:
    """The cubic (3, 4) on [t0, t1] with value and rate x0, v0 at t0 and x1, v1 at t1 (of
    x, y, z): c3 = x0 and c2 = v0 exactly, so a law built from it continues one whose
    value and rate at t0 are x0, v0."""
    h = t1 - t0
    x0, v0, x1, v1 = (np.asarray(a, dtype=float) for a in (x0, v0, x1, v1))
    d = x1 - x0
    c1 = (3.0 * d - h * (2.0 * v0 + v1)) / (h * h)
    c0 = (h * (v0 + v1) - 2.0 * d) / (h * h * h)
    return np.stack([c0, c1, v0, x0], axis=1)


def hermite_law(t, x, v) -> Segments:
    """The C^1 cubic Hermite law through times ``t`` (n,) with values ``x`` and rates
    ``v`` (n, 3)."""
    t = np.asarray(t, dtype=float)
    coef = np.stack([hermite(t[i], x[i], v[i], t[i + 1], x[i + 1], v[i + 1])
                     for i in range(len(t) - 1)])
    return Segments(t, coef)


def _address(ctx) -> int:
    """The address a controller's memory is at: an int is one; a ctypes pointer points
    to it; any other ctypes object (a Structure, a buffer) is it."""
    if isinstance(ctx, int):
        return ctx
    if isinstance(ctx, ctypes._Pointer):
        return ctypes.cast(ctx, ctypes.c_void_p).value
    return ctypes.addressof(ctx)


class CController:
    """A controller compiled to C: the address of its ``crt_controller_fn`` and its memory
    (``ctx``: a ctypes object (a Structure, a buffer), a pointer to one or an address, the
    function's state;
    ``keep``: what must stay alive while it runs)."""

    def __init__(self, address: int, ctx, keep=()):
        self.address, self.ctx, self.keep = address, ctx, keep


@dataclass
class Loop:
    """What closes the loop around a run (see the module's docstring).  ``noise``: the
    standard deviations of omega (rad/s), the attitude (rad), C's position (m) and its
    velocity (m/s) in what the controller reads; ``pushes``: rows (time, P_X, P_Y, P_Z,
    at_x, at_y, at_z), the impulse in fixed axes (N s) at a body point (body axes, m);
    ``channels``: on a law of several bodies, the outputs the controller's x, y, z drive
    (crt_control_channels: 3 j + c for point j's coordinate c, 3 n_points + r for rotor
    r's psi; -1 none; empty: one point's law)."""
    controller: object
    period: float = 0.0
    noise: tuple = (0.0, 0.0, 0.0, 0.0)
    seed: int = 0
    pushes: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    channels: tuple = ()        # a law of several bodies: the outputs x, y, z drive
    error: BaseException | None = field(default=None, repr=False)

    def __post_init__(self):
        self.pushes = np.ascontiguousarray(np.asarray(self.pushes, dtype=float)
                                           .reshape(-1, len(abi.PUSH_COLUMNS)))
        order = np.argsort(self.pushes[:, 0], kind="stable")
        self.pushes = np.ascontiguousarray(self.pushes[order])
        self._noise = np.ascontiguousarray(self.noise, dtype=float)
        self.log = np.zeros((LOG_ROWS, len(abi.LOG_COLUMNS)))
        self.rows: list = []

    # -- the controller as the C sees it --------------------------------------------------
    def _python_fn(self):
        controller = self.controller

        def call(_ctx, callp, max_knots, n_knots, knots, coef):
            try:
                c = callp.contents
                q = np.ctypeslib.as_array(c.q, (c.nq,)).copy()
                u = np.ctypeslib.as_array(c.u, (9,)).copy()
                out = controller(Call(c.t, REASONS[c.reason],
                                      EVENTS[c.event] if c.reason == 2 else "", q, u, c.k))
                if out is None:
                    return 0
                if isinstance(out, str) and out == STOP:
                    return -1
                n = len(out.knots)
                if not 2 <= n <= max_knots:
                    raise ValueError(f"the controller's law has {n} knots (2 to {max_knots})")
                kk = np.ctypeslib.as_array(knots, (max_knots,))
                cc = np.ctypeslib.as_array(coef, ((max_knots - 1) * 12,))
                kk[:n] = out.knots
                cc[:(n - 1) * 12] = np.asarray(out.coef, dtype=float).reshape(-1)
                n_knots[0] = n
                return 1
            except BaseException as exc:      # raised again after the run
                self.error = exc
                return -1
        return CONTROLLER_FN(call)

    def attach(self, lib, handle) -> None:
        """Fill a crt_control for this run and hand it to the session (after its law)."""
        self.error = None
        self.rows = []
        self._mem = ctypes.create_string_buffer(lib.crt_control_sizeof() + 64)
        self.handle = ctypes.c_void_p((ctypes.addressof(self._mem) + 63) // 64 * 64)
        if isinstance(self.controller, CController):
            fn, ctx = ctypes.c_void_p(self.controller.address), self.controller.ctx
        else:
            self._fn = self._python_fn()
            fn, ctx = ctypes.cast(self._fn, ctypes.c_void_p), None
        ctx_p = None if ctx is None else ctypes.c_void_p(_address(ctx))
        status = lib.crt_control_setup(self.handle, fn, ctx_p, float(self.period),
                                       self._noise.ctypes.data_as(DP), float(self.seed),
                                       self.pushes.ctypes.data_as(DP), len(self.pushes),
                                       self.log.ctypes.data_as(DP), len(self.log))
        if status != _S["ok"]:
            raise ValueError("the runtime refused the loop (a negative period or noise, "
                             "pushes not in time order or not finite, or pushes on a model "
                             "without them: pushes need the general model)")
        if self.channels:
            self._channels = (ctypes.c_int * len(self.channels))(*self.channels)
            if lib.crt_control_channels(self.handle, len(self.channels),
                                        self._channels) != _S["ok"]:
                raise ValueError("the runtime refused the controller's channels (at most "
                                 "three outputs of the law)")
        if lib.crt_set_control(handle, self.handle) != _S["ok"]:
            raise ValueError("the runtime has no law to close the loop on (or the "
                             "controller's channels are not outputs of its law of bodies)")

    def drain(self, lib) -> None:
        """Take the rows of the realised law written since the last drain."""
        n = lib.crt_control_log_count(self.handle)
        if n:
            self.rows.append(self.log[:n].copy())
            lib.crt_control_log_taken(self.handle)

    def fault(self, lib) -> str:
        return abi.names(abi.CONTROL_FAULTS)[lib.crt_control_fault(self.handle)]

    def law_rows(self) -> np.ndarray:
        """The realised law's log: rows of abi.LOG_COLUMNS."""
        return np.concatenate(self.rows) if self.rows else np.zeros((0, len(abi.LOG_COLUMNS)))


def realised_law(rows: np.ndarray, source: str = "the realised law") -> TableLaw:
    """The law a closed loop ran, as a table law (each piece re-expanded about the time
    it took over), from the log rows (knot, t_from, t_to, c0..c3 of x, y, z)."""
    rows = np.asarray(rows, dtype=float)
    if len(rows) == 0:
        raise ValueError("the controller never set a law")
    knots = np.r_[rows[:, 1], rows[-1, 2]]
    coef = np.empty((len(rows), 3, 4))
    for i, row in enumerate(rows):
        d = row[1] - row[0]                    # the cubic about t_from: s = s' + d
        for c in range(3):
            a0, a1, a2, a3 = row[3 + 4 * c:7 + 4 * c]
            coef[i, c] = (a0, 3 * a0 * d + a1, (3 * a0 * d + 2 * a1) * d + a2,
                          ((a0 * d + a1) * d + a2) * d + a3)
    return TableLaw(knots=knots, coef=np.ascontiguousarray(coef), ends="free", source=source)


def measure_noise_std(noise: dict | None) -> tuple:
    """(omega, attitude, com, com_velocity) from a [disturbance].noise table."""
    noise = noise or {}
    return tuple(float(noise.get(k) or 0.0) for k in ("omega", "attitude", "com",
                                                      "com_velocity"))

"""The SciPy peer: ``solve_ivp`` on the derived functions of the ``general`` model, with
impacts.  One integrator, used by the benchmarks (the ``Scipy`` route of
:mod:`derive.bench.routes`) and by the planner's re-simulation of a planned scene
(:mod:`derive.planner.resim`); it imports neither.

* flight: ``q' = rhs(q, u(t), p)`` (E1.4, E1.7) with any of ``solve_ivp``'s methods;
* impacts: the height ``h`` of the lowest point S (E1.14) is a terminal event (direction
  -1); at the event, if S approaches the plane (``v_n < 0``), the impact map (E1.10-E1.16)
  gives ``q+``; the integration then steps a hair (:data:`HAIR`) without the event, so
  that S leaves the plane before the event is armed again;
* an evaluation budget and a cap on the number of impacts stop a run with a status
  (``stopped: ...``), never a hang.

The functions come from the caller (CasADi's, the NumPy evaluation or the generated C:
each with the generated signatures, returning a tuple of output arrays), so that each
user measures the evaluation it wants.  Persistent contact is not modelled: a scene
that comes to rest on the plane makes the impacts accumulate until the cap.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp

from . import layout

HAIR = 1e-9                  # s: integrated without the event after each impact
# the vertical n in body axes (a31, a32, a33): the lowest point of the shape depends on it
N_ROWS = layout.GENERAL.n


class StopRun(RuntimeError):
    """A run exceeded its evaluation budget or its number of impacts."""


@dataclass(frozen=True)
class Functions:
    """The derived functions, generated signatures: ``rhs(q, u, p) -> (q',)``,
    ``gap(q, u, s, p) -> (h, v_n)``, ``impact(q, u, s, p, e) -> (q+, I)``,
    ``lowest(n, center, size) -> (s,)``."""
    rhs: Callable
    gap: Callable | None = None
    impact: Callable | None = None
    lowest: Callable | None = None


@dataclass
class Path:
    """A hybrid run: every accepted step (or the ``t_eval`` grid), the impacts."""
    t: np.ndarray                 # (n,)
    q: np.ndarray                 # (n, 18)
    impacts: list = field(default_factory=list)   # dicts: t, I, v_minus, v_plus, q_minus, q_plus
    status: str = "done"
    evaluations: int = 0


class Hybrid:
    """``run(t0, t_end, q0, t_eval=None) -> Path`` for a law ``u(t) -> (9,)`` and
    parameters ``p``; ``contact`` arms the event (the scene has a plane and a shape)."""

    def __init__(self, functions: Functions, law: Callable, p, *, contact: bool,
                 e: float = 1.0, center=(0.0, 0.0, 0.0), size=(), method: str = "DOP853",
                 rtol: float = 1e-12, atol: float | None = None, budget: float = np.inf,
                 max_impacts: int = 20000):
        self.fn, self.law, self.p = functions, law, np.asarray(p, dtype=float)
        self.contact, self.e = contact, [float(e)]
        self.center, self.size = np.asarray(center, dtype=float), list(size)
        self.method, self.rtol = method, rtol
        self.atol = rtol * 1e-2 if atol is None else atol
        self.budget, self.max_impacts = budget, max_impacts
        self.calls = 0

    # ---- the functions at (t, q) --------------------------------------------------------
    def rhs(self, t, q):
        self.calls += 1
        if self.calls > self.budget:
            raise StopRun("evaluation budget exhausted")
        return self.fn.rhs(q, self.law(t), self.p)[0]

    def lowest(self, q):
        return self.fn.lowest(q[N_ROWS], self.center, self.size)[0]

    def gap(self, t, q) -> tuple[float, float]:
        h, vn = self.fn.gap(q, self.law(t), self.lowest(q), self.p)
        return float(np.ravel(h)[0]), float(np.ravel(vn)[0])

    def _solve(self, t0, t1, q, events=None, t_eval=None):
        return solve_ivp(self.rhs, (t0, t1), q, method=self.method, rtol=self.rtol,
                         atol=self.atol, events=events, t_eval=t_eval)

    # ---- a run --------------------------------------------------------------------------
    def run(self, t0: float, t_end: float, q0, t_eval=None) -> Path:
        """Integrate from ``(t0, q0)`` to ``t_end``: every accepted step and both sides of
        each impact, or the states on ``t_eval`` (increasing, in [t0, t_end])."""
        self.calls = 0
        event = None
        if self.contact:
            def event(t, q):
                return self.gap(t, q)[0]
            event.terminal, event.direction = True, -1
        t, q = float(t0), np.asarray(q0, dtype=float)
        grid = None if t_eval is None else np.asarray(t_eval, dtype=float)
        ts, qs = ([np.array([t])], [q[None, :]]) if grid is None else ([], [])
        states = None if grid is None else np.empty((len(grid), q.shape[0]))
        filled, impacts, status = 0, [], "done"
        try:
            while t < t_end - 1e-15:
                rest = None if grid is None else grid[filled:]
                sol = self._solve(t, t_end, q, event,
                                  rest if rest is not None and len(rest) else None)
                y = np.asarray(sol.y).reshape(q.shape[0], -1)
                if grid is None:
                    ts.append(sol.t[1:])
                    qs.append(y[:, 1:].T)
                elif len(rest):
                    states[filled:filled + y.shape[1]] = y.T
                    filled += y.shape[1]
                if sol.status < 0:
                    status = "failed: " + sol.message
                    break
                if sol.status == 0:
                    break
                t, q_minus = float(sol.t_events[0][0]), np.asarray(sol.y_events[0][0])
                q = self._impact(t, q_minus, impacts)
                if grid is None and q is not q_minus:       # both sides of the impact
                    ts.append(np.array([t]))
                    qs.append(q[None, :])
                if len(impacts) > self.max_impacts:
                    raise StopRun("impacts do not stop")
                step = self._solve(t, min(t + HAIR, t_end), q)
                t, q = float(step.t[-1]), step.y[:, -1]
        except StopRun as exc:
            status = f"stopped: {exc}"
        if grid is None:
            return Path(np.concatenate(ts), np.vstack(qs), impacts, status, self.calls)
        return Path(grid[:filled], states[:filled], impacts, status, self.calls)

    def _impact(self, t, q_minus, impacts):
        """The impact map at an event where S approaches; else the state unchanged."""
        _, vn = self.gap(t, q_minus)
        if vn >= 0:
            return q_minus
        q_plus, impulse = self.fn.impact(q_minus, self.law(t), self.lowest(q_minus), self.p,
                                         self.e)
        q_plus = np.asarray(q_plus, dtype=float).ravel()
        impacts.append({"t": t, "I": float(np.ravel(impulse)[0]), "v_minus": vn,
                        "v_plus": self.gap(t, q_plus)[1], "q_minus": q_minus,
                        "q_plus": q_plus})
        return q_plus

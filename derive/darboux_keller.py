"""A frictional impact integrated numerically: Darboux–Keller in the normal impulse.

The reference the C runtime's impacts are compared with (NumPy and SciPy; the rates are
the derived ones of :mod:`derive.friction`, packaged by :mod:`derive.friction_models` and
evaluated by :func:`derive.emit.numpy_backend.numpy_function`).

During the impact the configuration is fixed, so the Delassus matrix W is a constant
and the velocity of S is the state (``v = v_S``, fixed axes).  The normal impulse ``p``
is the independent variable:

1. **Slip** (``v_t != 0``): ``dv/dp = W (e_Z - mu_f sigma)``.  Integrated by SciPy's
   DOP853 with ``v_t = rho (cos theta, sin theta)``: ``rho`` may cross zero smoothly
   (the direction ``theta`` is continuous), so the stop of the slip is a true sign
   change of ``rho`` for the event search, where the Cartesian ``|v_t|`` would only
   touch zero.
2. **Stop** of the slip: stick if ``|tau| <= mu_f`` (``tau = z_t/z_Z``, ``W z = e_Z``);
   otherwise re-slide along the ray ``sigma(c)`` (the unique ``c > 0`` with
   ``|sigma(c)| = 1``, Newton from ``c = 0``).  Both hold to the end of the impact (W is
   constant): the rates are constant there and the remaining events are solved in
   closed form (``E_n`` is quadratic in ``p``).
3. **Ends**: compression where ``v_Z`` crosses 0 upwards; restitution where the model's
   termination expression (``derive.friction.darboux_keller().terminations``) vanishes.

``restitution="newton"`` (``v_n+ = -e v_n-``) is refused unless the normal velocity
is linear in ``p`` whatever the slip does, ``mu_f |W_tn| = 0`` (``mu_f = 0``, or a
normal impulse that sets up no tangential velocity of S): elsewhere Newton's law can
make an impact gain energy once the slip stops or turns (Kane and Levinson's double
pendulum), and where it is accepted it equals the other two models.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import sympy as sp

RESTITUTION = ("energetic", "poisson", "newton")


class ImpactJam(RuntimeError):
    """The normal velocity of S stops growing with the impulse before the impact ends
    (Painlevé's jam: ``dv_n/dp <= 0`` while slipping with a large ``mu_f``)."""


@dataclass
class Impact:
    impulse: np.ndarray            # P, total impulse at S (fixed axes)
    q_plus: np.ndarray | None      # state after (None when only W and v were given)
    v_minus: np.ndarray            # velocity of S before (fixed axes)
    v_plus: np.ndarray             # and after
    p_compression: float           # the normal impulse at the end of compression
    work_normal: float             # E_n = int v_Z dp (-> E_n <= 0 for "energetic")
    work_friction: float           # E_t = int (v_t, dP_t) <= 0
    W: np.ndarray                  # the Delassus matrix (3x3)
    events: list = field(default_factory=list)   # (p, what), in order


@lru_cache(maxsize=None)
def _functions():
    from . import friction as fr
    from .emit.numpy_backend import numpy_function
    dk = fr.darboux_keller()
    W_args = list(fr.W_UPPER)
    slip = sp.lambdify([list(fr.SIGMA), W_args, fr.mu_f], list(dk.slip_rate), modules="numpy")
    return {"delassus": numpy_function("general_delassus"),
            "apply": numpy_function("general_apply_impulse"),
            "stick": numpy_function("impulse_stick_rate"),
            "resliding": numpy_function("impulse_resliding"),
            "slip": slip}


def upper(W: np.ndarray) -> np.ndarray:
    return np.array([W[0, 0], W[0, 1], W[0, 2], W[1, 1], W[1, 2], W[2, 2]])


def full(w6) -> np.ndarray:
    a, b, c, d, e, f = np.asarray(w6, dtype=float).ravel()
    return np.array([[a, b, c], [b, d, e], [c, e, f]])


def newton_is_consistent(W: np.ndarray, mu_f: float, tol: float = 1e-12) -> bool:
    """``v_Z`` is linear in ``p`` whatever the slip does: ``mu_f |W_tn| = 0``."""
    return mu_f * float(np.hypot(W[0, 2], W[1, 2])) <= tol * float(np.abs(W).max())


def resliding_ray(W: np.ndarray, mu_f: float) -> tuple[float, np.ndarray]:
    """``(c, sigma)``: the re-sliding ray where stick is impossible (Newton on the
    convex, decreasing ``f(c) = |sigma(c)|^2 - 1`` from ``c = 0``: the iterates rise
    monotonically to the root, so the first step that does not rise ends it)."""
    f = _functions()["resliding"]
    w6 = upper(W)
    c = 0.0
    for _ in range(100):
        _, fc, dfc = f(w6, [mu_f], [c])
        step = -float(fc[0]) / float(dfc[0])
        if not step > 4e-16 * c:
            break
        c += step
    else:
        raise RuntimeError("re-sliding: Newton's method did not converge")
    sigma, _, _ = f(w6, [mu_f], [c])
    return c, np.asarray(sigma, dtype=float)


def _first_root(a2: float, a1: float, a0: float) -> float | None:
    """Smallest root >= 0 of ``a2 x^2 + a1 x + a0`` where it crosses upwards."""
    if a2 == 0.0:
        return -a0 / a1 if a1 > 0.0 and -a0 / a1 >= 0.0 else None
    disc = a1 * a1 - 4.0 * a2 * a0
    if disc < 0.0:
        return None
    r = np.sqrt(disc)
    # the roots, stably
    qv = -0.5 * (a1 + np.copysign(r, a1))
    roots = sorted([qv / a2, a0 / qv] if qv != 0.0 else [0.0, 0.0])
    for x in roots:
        if x >= -1e-15 * max(1.0, abs(roots[-1])) and 2.0 * a2 * x + a1 >= 0.0:
            return max(x, 0.0)
    return None


def integrate(W: np.ndarray, v0: np.ndarray, mu_f: float, e: float,
              restitution: str = "energetic", rtol: float = 1e-12,
              strict: bool = True) -> Impact:
    """The impact for a Delassus matrix ``W`` (3x3) and a velocity of S ``v0`` with
    ``v0[2] < 0``.  ``strict=False`` lets ``newton`` run where it is not
    energy-consistent (to study that: tests/test_friction_literature.py)."""
    if restitution not in RESTITUTION:
        raise ValueError(f"restitution must be one of {', '.join(RESTITUTION)}, "
                         f"not {restitution!r}")
    if not 0.0 <= e <= 1.0:
        raise ValueError(f"e must be in [0, 1] (got {e})")
    if not mu_f >= 0.0:
        raise ValueError(f"mu_f must be >= 0 (got {mu_f})")
    W = np.asarray(W, dtype=float)
    v0 = np.asarray(v0, dtype=float)
    if not v0[2] < 0.0:
        raise ValueError(f"no impact: the normal velocity of S is {v0[2]} >= 0")
    if strict and restitution == "newton" and not newton_is_consistent(W, mu_f):
        raise ValueError("restitution 'newton' (v_n+ = -e v_n-) is energy-consistent only "
                         "where mu_f |W_tn| = 0; use 'energetic' (or 'poisson')")
    run = _Run(W, v0, mu_f, e, restitution, rtol)
    if mu_f > 0.0 and np.hypot(v0[0], v0[1]) > 0.0:
        run.slip()
    if not run.done:
        run.constant_rates()
    p_c = run.p_c
    return Impact(impulse=np.array([run.Pt[0], run.Pt[1], run.p]), q_plus=None, v_minus=v0,
                  v_plus=run.v, p_compression=float(p_c), work_normal=run.En,
                  work_friction=run.Et, W=W, events=run.events)


class _Run:
    """The state of one Darboux–Keller integration (see :func:`integrate`)."""

    def __init__(self, W, v0, mu_f, e, restitution, rtol):
        self.W, self.v0, self.mu_f, self.e = W, v0, mu_f, e
        self.restitution, self.rtol = restitution, rtol
        self.w6 = upper(W)
        self.scale_v = float(np.abs(v0).max())
        self.scale_p = self.scale_v / float(W[2, 2])
        # beyond this impulse the impact is reported as a jam: 1e4 times what stops v_Z
        # at the smallest rate W allows
        self.p_max = 1e4 * (1.0 + e) * self.scale_v / float(np.linalg.eigvalsh(W)[0])
        self.v = v0.copy()
        self.Pt = np.zeros(2)
        self.p = self.En = self.Et = 0.0
        self.p_c = self.E_c = None
        self.events: list = []
        self.done = False

    def _termination(self, p, v_n, En) -> float:
        """Zero where restitution ends (derive.friction: terminations)."""
        if self.restitution == "energetic":
            return En - (1.0 - self.e ** 2) * self.E_c
        if self.restitution == "poisson":
            return p - (1.0 + self.e) * self.p_c
        return v_n + self.e * self.v0[2]

    def _compression_ends(self, p, En):
        self.p_c, self.E_c = p, En
        self.events.append((p, "compression ends"))

    def slip(self) -> None:
        """Stage 1: DOP853 in polar slip coordinates until the slip stops or the impact
        ends."""
        from scipy.integrate import solve_ivp
        slip_rate, w6, mu_f = _functions()["slip"], self.w6, self.mu_f

        def rate(_p, y):
            rho, th = y[0], y[1]
            sig = np.array([np.cos(th), np.sin(th)])
            c = np.asarray(slip_rate(sig, w6, mu_f), dtype=float).ravel()
            return [sig @ c[:2], (sig[0] * c[1] - sig[1] * c[0]) / rho, c[2],
                    -mu_f * sig[0], -mu_f * sig[1], y[2], -mu_f * rho]

        # the slip speed reaches zero with its direction converging only as a power of
        # rho (dtheta/dp ~ rho^(kappa - 1)): stop at rho = delta, then the last stretch
        # at the rates there (an error of order delta in v)
        delta = self.rtol * self.scale_v

        def stop(_p, y):
            return y[0] - delta

        def compression(_p, y):
            return y[2]

        def end(p, y):
            return self._termination(p, y[2], y[5])

        stop.terminal, stop.direction = True, -1
        compression.terminal, compression.direction = True, 1
        end.terminal, end.direction = True, 1
        v, sv, sp_ = self.v, self.scale_v, self.scale_p
        y = np.array([np.hypot(v[0], v[1]), np.arctan2(v[1], v[0]), v[2], 0.0, 0.0, 0.0, 0.0])
        atol = 1e-3 * self.rtol * np.array([sv, 1.0, sv, sp_, sp_, sv * sp_, sv * sp_])
        p = 0.0
        while True:
            if self.p_c is not None and self.e == 0.0:
                self.events.append((p, "restitution ends"))
                self.done = True
                break
            events = [stop, compression] if self.p_c is None else [stop, end]
            sol = solve_ivp(rate, (p, self.p_max), y, method="DOP853", rtol=self.rtol,
                            atol=atol, events=events)
            if sol.status == -1:
                raise RuntimeError(f"Darboux-Keller integration failed: {sol.message}")
            hit = [k for k, te in enumerate(sol.t_events) if len(te)]
            if not hit:
                raise ImpactJam(f"the impact did not end within p = {self.p_max:.3g} "
                                "(dv_n/dp <= 0 while slipping: Painleve's jam)")
            k = min(hit, key=lambda j: sol.t_events[j][0])
            p, y = float(sol.t_events[k][0]), np.array(sol.y_events[k][0])
            if k == 0:
                dy = np.asarray(rate(p, y), dtype=float)
                if dy[0] < 0.0:
                    p, y = p - y[0] / dy[0], y - y[0] / dy[0] * dy
                y[0] = 0.0
                self.events.append((p, "slip stops"))
                break
            if self.p_c is None:
                y[2] = 0.0
                self._compression_ends(p, float(y[5]))
                continue
            self.events.append((p, "restitution ends"))
            self.done = True
            break
        self.p = p
        self.v = np.array([y[0] * np.cos(y[1]), y[0] * np.sin(y[1]), y[2]])
        self.Pt = y[3:5].copy()
        self.En, self.Et = float(y[5]), float(y[6])

    def constant_rates(self) -> None:
        """Stage 2: constant rates to the end of the impact: no friction (mu_f = 0), stick
        (|tau| <= mu_f) or the re-sliding ray; the events in closed form."""
        W, mu_f, e = self.W, self.mu_f, self.e
        c_ray = 0.0
        if mu_f == 0.0:
            dv, dPt = W[:, 2].copy(), np.zeros(2)
        else:
            y7 = np.array([0.0, 0.0, self.v[2], *self.Pt, self.En, self.Et])
            dy, tau, margin = _functions()["stick"](y7, self.w6, [mu_f])
            if margin[0] >= -1e-12 * mu_f * mu_f:
                dv, dPt = np.array([0.0, 0.0, dy[2]]), np.asarray(tau, dtype=float)
                self.events.append((self.p, "stick"))
            else:
                c_ray, sigma = resliding_ray(W, mu_f)
                dv = W @ np.array([-mu_f * sigma[0], -mu_f * sigma[1], 1.0])
                dPt = -mu_f * sigma
                self.events.append((self.p, "re-slide"))
        a_n, v_n, p0, En0 = float(dv[2]), float(self.v[2]), self.p, self.En
        if self.p_c is None:
            if a_n <= 0.0:
                raise ImpactJam("dv_n/dp <= 0 with v_n < 0 at constant rates: the "
                                "compression would not end (Painleve's jam)")
            d_c = -v_n / a_n
            self._compression_ends(p0 + d_c, En0 + v_n * d_c + 0.5 * a_n * d_c * d_c)
        if e == 0.0:
            d = self.p_c - p0
        elif self.restitution == "energetic":
            d = _first_root(0.5 * a_n, v_n, En0 - (1.0 - e * e) * self.E_c)
        elif self.restitution == "poisson":
            d = (1.0 + e) * self.p_c - p0
        else:
            d = (-e * self.v0[2] - v_n) / a_n if a_n > 0.0 else None
        if d is None or d < 0.0:
            raise ImpactJam("the restitution does not end at constant rates")
        self.p = p0 + d
        self.v = self.v + dv * d
        self.Pt = self.Pt + dPt * d
        self.En = En0 + v_n * d + 0.5 * a_n * d * d
        self.Et = self.Et - 0.5 * mu_f * c_ray * d * d
        self.events.append((self.p, "restitution ends"))
        self.done = True


def impact(q, u, s, params, mu_f: float, e: float, restitution: str = "energetic",
           rtol: float = 1e-12, strict: bool = True) -> Impact:
    """The frictional impact of the ``general`` state ``q`` (law ``u``, lowest point
    ``s``, parameters ``p = (M, m, J_x, J_y, J_z, g)``): W and v_S from
    ``general_delassus``, Darboux–Keller, and the state after from
    ``general_apply_impulse``."""
    fn = _functions()
    w6, v_S = fn["delassus"](q, u, s, params)
    result = integrate(full(w6), v_S, mu_f, e, restitution, rtol, strict)
    (q_plus,) = fn["apply"](q, u, s, params, result.impulse)
    result.q_plus = q_plus
    return result

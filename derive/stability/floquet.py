"""Floquet multipliers of periodic free-flight motions (the stationary rotations of
C3.1, C4.1–C4.3, the translational motion of C2.5), with the checks that make them
trustworthy, and long perturbed runs where the linear test is critical.

The state is the ``vertical`` layout (Z_C, Z_C', omega, n): in free flight Z_C decouples
(a Jordan block of multipliers 1) and (omega, n) carry the perturbed rotation, n being the
body components of the fixed axis that the unperturbed rotation keeps.

Checks of each monodromy matrix M:

* Liouville: ``det M = exp(int_0^T tr(df/dq) dt)``, the trace integrated by Gauss–Legendre
  quadrature from a NumPy evaluation of the derived Jacobian;
* trivial multipliers: each integral C (|K|^2 of E1.9, the component of K along the fixed
  axis n of E3.8, |n|^2, and Z_C' in free flight) gives a left eigenvector of M with
  multiplier 1, ``grad C^T M = grad C^T`` at the base point;
* a central finite-difference monodromy from perturbed runs of the same equations.

The verdict is read from two blocks of M: (omega, n), the perturbed rotation, and omega
alone (a closed subsystem: E1.7 does not involve n; C2.5 is a claim about omega only).
A block is unstable when some |rho| > 1 + tol; when every multiplier is on the unit
circle it is critical, and a Jordan block at rho = 1 (integrals and families of periodic
motions put multipliers there) predicts linear growth, while a semisimple one does not.
Long perturbed runs (``long_periods``) then tell bounded from growing deviations.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
import sympy as sp

from .. import models as dm
from ..emit.casadi_backend import build_function
from ..emit.numpy_backend import compile_spec
from .. import abi, layout
from ..runtime import choice
from ..runtime.driver import simulate
from ..scene import Scene, SceneError
from ..scene.law.period import NotPeriodic, common_period
from .specialise import common as _common
from .specialise import specialise
from .variational import Monodromy

UNIT_TOL = 1e-6         # |rho| - 1 beyond this: unstable


def complex_pairs(values) -> list:
    """Complex numbers as [re, im] pairs (JSON)."""
    return [[float(v.real), float(v.imag)] for v in values]


@dataclass
class Analysis:
    period: float
    multipliers: np.ndarray
    monodromy: np.ndarray
    det: float
    liouville: float
    trivial: dict
    fd_difference: float
    blocks: dict                  # "omega, n" and "omega": see ``block_verdict``
    verdict: str
    long_runs: list = field(default_factory=list)

    @property
    def max_modulus(self) -> float:
        return float(np.max(np.abs(self.multipliers)))

    def checks(self) -> dict:
        """Each check's discrepancy, its bound and whether it holds."""
        scale = max(1.0, float(np.max(np.abs(self.monodromy))))
        rows = {"liouville": (abs(self.det - self.liouville) / max(1.0, abs(self.det)), 1e-8),
                "finite_difference": (self.fd_difference, 1e-5 * scale)}
        rows.update({f"trivial {name}": (v, 1e-8 * scale) for name, v in self.trivial.items()})
        return {k: {"value": v, "bound": bound, "ok": bool(v <= bound)}
                for k, (v, bound) in rows.items()}

    def as_dict(self) -> dict:
        return {"kind": "periodic free flight", "period": self.period,
                "multipliers": complex_pairs(self.multipliers),
                "moduli": [float(abs(m)) for m in self.multipliers],
                "max_modulus": self.max_modulus, "det": self.det, "liouville": self.liouville,
                "trivial_multipliers": self.trivial,
                "finite_difference_check": self.fd_difference, "checks": self.checks(),
                "blocks": self.blocks, "verdict": self.verdict, "long_runs": self.long_runs}


def law_period(scene: Scene) -> float:
    """The common period of the point's law (derive/scene/law/period.py): every sin/cos
    argument must be k t + c with frequencies commensurate (ratios of small integers);
    constant laws have none."""
    try:
        return common_period(scene.law.sympy())
    except NotPeriodic as exc:
        if exc.constant:
            raise SceneError("[stability].period", "is required: a constant law has no "
                                                   "period") from None
        raise SceneError("[point].law", f"{exc}: set [stability].period") from None


V = layout.VERTICAL


def initial_state(scene: Scene) -> np.ndarray:
    return choice.start(scene, "vertical").q0


class TraceOfJacobian:
    """tr(df/dq)(t, q): the diagonal of the derived flight Jacobian
    (:func:`derive.models.flight_jacobian`) specialised to the scene, evaluated with
    NumPy (an evaluation independent of the compiled variational runtime)."""

    def __init__(self, scene: Scene, base: str = "vertical"):
        subs, defs = _common(scene)
        q, labels = dm.STATES[base], dm.STATE_LABELS[base]
        jac = dm.flight_jacobian(base)
        n = len(q)
        A = jac.outputs[0].entries
        trace = sum((A[i * n + i] for i in range(n)), sp.Integer(0))
        self.fn = compile_spec(specialise(jac, subs, defs, q, labels, "trace",
                                          outputs=[("tr", (trace,), ("tr",))]))

    def __call__(self, t: float, q) -> float:
        return float(self.fn([t], np.asarray(q, dtype=float))[0][0])


def analyse(scene: Scene, period: float | None = None, fd_eps: float = 1e-6,
            rtol: float = 1e-12, long_periods: int = 0,
            perturbations=(1e-6, 1e-4, 1e-2), mono: Monodromy | None = None,
            progress: bool = False) -> Analysis:
    """Multipliers of the free-flight motion of ``scene`` over one period."""
    T = period or law_period(scene)
    mono = mono or Monodromy(scene, rtol=rtol)
    q0 = initial_state(scene)
    qT, M = mono.flow(scene.t0, q0, T)
    drift = np.max(np.abs(qT[2:] - q0[2:]))
    if drift > 1e-6 * max(1.0, np.max(np.abs(q0[2:]))):
        raise SceneError("[initial]", f"the motion is not periodic with period {T:.6g}: "
                                      f"omega and n change by {drift:.2e} over a period "
                                      "(start on a stationary rotation, or set "
                                      "[stability].period)")
    rho = np.linalg.eigvals(M)
    det = float(np.linalg.det(M))
    # Liouville: the trace along the (periodic) base solution, Gauss-Legendre on 64
    # panels; the base solution is carried from node to node
    tr = TraceOfJacobian(scene)
    nodes, weights = np.polynomial.legendre.leggauss(12)
    panels = np.linspace(0.0, T, 65)
    total, t_prev, q_prev = 0.0, 0.0, q0
    for a, b in zip(panels[:-1], panels[1:]):
        values = []
        for tk in 0.5 * (b - a) * nodes + 0.5 * (a + b):
            q_prev, _ = mono.flow(scene.t0 + t_prev, q_prev, tk - t_prev)
            t_prev = tk
            values.append(tr(scene.t0 + tk, q_prev))
        total += 0.5 * (b - a) * float(np.dot(weights, values))
    liouville = math.exp(total)
    trivial = {name: float(np.max(np.abs(g @ M - g)) / max(np.max(np.abs(g)), 1e-300))
               for name, g in integral_gradients(scene, q0).items()}
    # finite differences of the flow of the same equations
    n = len(q0)
    fd = np.empty((n, n))
    for k in range(n):
        dq = np.zeros(n)
        dq[k] = fd_eps
        qp, _ = mono.flow(scene.t0, q0 + dq, T)
        qm, _ = mono.flow(scene.t0, q0 - dq, T)
        fd[:, k] = (qp - qm) / (2 * fd_eps)
    fd_diff = float(np.max(np.abs(fd - M)))
    # Z_C, Z_C' decouple in free flight (a Jordan block at 1 that says nothing about the
    # rotation); omega alone is a closed subsystem (E1.7 does not involve n)
    blocks = {"omega, n": block_verdict(M[2:, 2:]), "omega": block_verdict(M[2:5, 2:5])}
    out = Analysis(T, rho, M, det, liouville, trivial, fd_diff, blocks,
                   blocks["omega, n"]["verdict"])
    if long_periods and not out.verdict.startswith("unstable"):
        out.long_runs = [long_run(scene, T, long_periods, eps, progress=progress)
                         for eps in perturbations]
        out.verdict += "; perturbed runs: " + "; ".join(
            f"deviations in {label} {runs_verdict(out.long_runs, sfx)}"
            for label, sfx in (("(omega, n)", ""), ("omega", "_omega")))
    return out


def runs_verdict(runs: list, suffix: str = "") -> str:
    """What perturbed runs of several sizes eps say: Lyapunov stability needs deviations
    that stay bounded *and* shrink with eps (max deviation / eps about constant)."""
    ratios = [r["max_deviation" + suffix] / r["eps"] for r in runs]
    growths = [r["growth" + suffix] for r in runs]
    if any(g == "growing" for g in growths):
        return "grow (by more than 1e3 times the perturbation)"
    spread = max(ratios) / max(min(ratios), 1e-300)
    if spread > 10 or any(g.startswith("growing") for g in growths):
        worst = max(r["max_deviation" + suffix] for r in runs)
        return (f"drift, up to {worst:.2g}, not in proportion to eps (a run's max "
                f"deviation / its eps from {min(ratios):.3g} to {max(ratios):.3g}): not "
                "Lyapunov-stable, the drift is slow (algebraic)")
    return (f"stay bounded, in proportion to eps (a run's max deviation / its eps "
            f"{min(ratios):.3g} to {max(ratios):.3g})")


def integral_gradients(scene: Scene, q0) -> dict:
    """Gradients in the vertical layout, at q0 and time t0, of the integrals of free
    flight: |K|^2 (E1.9) and K.n (E3.8) by CasADi's AD of the derived kinetic moment
    (:func:`derive.models.kinetic_moment`) specialised to the scene, |n|^2 and Z_C'."""
    subs, defs = _common(scene)
    q, labels = dm.STATES["vertical"], dm.STATE_LABELS["vertical"]
    K_fn = build_function(specialise(dm.kinetic_moment("vertical"), subs, defs, q, labels,
                                     "K"))
    x = ca.SX.sym("q", len(q))
    K = K_fn(scene.t0, x)
    grad = ca.Function("grad", [x], [ca.gradient(ca.dot(K, K), x),
                                     ca.gradient(ca.dot(K, x[V.n]), x)])
    gK2, gKn = (np.array(v.full()).ravel() for v in grad(np.asarray(q0, dtype=float)))
    n = np.asarray(q0[V.n], dtype=float)
    grads = {"|K|^2": gK2, "K.n": gKn,
             "|n|^2": V.assemble(Z=0.0, Zd=0.0, omega=np.zeros(3), n=2 * n),
             "Z_C'": V.assemble(Z=0.0, Zd=1.0, omega=np.zeros(3), n=np.zeros(3))}
    return {k: g for k, g in grads.items() if np.max(np.abs(g)) > 0}


def block_verdict(B: np.ndarray, tol: float = UNIT_TOL) -> dict:
    """Multipliers of one block of M and what they say: unstable (some |rho| > 1 + tol),
    critical with a Jordan block at 1 (algebraic multiplicity of rho = 1 above the
    geometric one: deviations grow linearly in t), or linearly stable (every multiplier
    on the unit circle, semisimple at 1)."""
    rho = np.linalg.eigvals(B)
    worst = float(np.max(np.abs(rho)))
    algebraic = int(np.sum(np.abs(rho - 1.0) < 1e-5))
    sv = np.linalg.svd(B - np.eye(len(B)), compute_uv=False)
    geometric = int(np.sum(sv < 1e-8 * max(1.0, float(np.max(np.abs(B))))))
    if worst > 1 + tol:
        verdict = f"unstable (max |rho| = {worst:.6f})"
    elif geometric < algebraic:
        verdict = (f"critical with a Jordan block at rho = 1 (algebraic multiplicity "
                   f"{algebraic}, geometric {geometric}): linear growth in t")
    else:
        verdict = "linearly stable (every multiplier on the unit circle, semisimple)"
    return {"multipliers": complex_pairs(rho), "max_modulus": worst,
            "rho_1_algebraic": algebraic, "rho_1_geometric": geometric, "verdict": verdict}


def long_run(scene: Scene, T: float, periods: int, eps: float, seed: int = 0,
             progress: bool = False) -> dict:
    """Perturb omega and the axis by ``eps`` (a fixed random direction, n renormalised)
    and follow the nonlinear motion for ``periods`` periods, sampled once per period.
    The runs use the momentum form (method ``lie``): |K| and K.n are exact whatever the
    length of the run, so a drift seen here is the motion's, not the integrator's."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=6)
    d /= np.linalg.norm(d)
    scale = max(1.0, float(np.linalg.norm(scene.omega)))
    omega = np.asarray(scene.omega, dtype=float) + eps * d[:3] * scale
    A = scene.A0.copy()
    tilt = eps * d[3:]
    # rotate the body slightly: A <- A (I + skew(tilt)), re-orthonormalised
    K = np.array([[0, -tilt[2], tilt[1]], [tilt[2], 0, -tilt[0]], [-tilt[1], tilt[0], 0]])
    A = A @ (np.eye(3) + K)
    u, _, vt = np.linalg.svd(A)
    A = u @ vt
    doc = {"name": scene.name,
           "body": {"mass": scene.M, "inertia": list(scene.J), "shape": "none"},
           "point": {"mass": scene.m, "law": list(scene.law_text)},
           "initial": {"time": scene.t0, "com": list(scene.com),
                       "com_velocity": list(scene.com_velocity), "omega": omega.tolist(),
                       "matrix": A.tolist()},
           "run": {"duration": periods * T, "method": "lie", "rtol": 1e-11, "atol": 1e-13,
                   "g": scene.g, "outputs": ["omega"], "output_dt": T, "model": "vertical"}}
    res = simulate(doc, progress=progress)
    rows = res.row_kind == abi.ROW_KIND["step"]
    Q = res.model_q[rows]
    base = np.r_[scene.omega, scene.A0[2]]
    both = growth(np.max(np.abs(np.c_[Q[:, V.omega], Q[:, V.n]] - base), axis=1))
    omega_only = growth(np.max(np.abs(Q[:, V.omega] - base[:3]), axis=1))
    return {"eps": eps, "periods": periods, **both,
            **{f"{k}_omega": v for k, v in omega_only.items()}, "status": res.status}


def growth(dev: np.ndarray) -> dict:
    """How a deviation sampled once per period grows: the ratio of its running maximum
    to its start, and the exponent of that envelope against time over the last 80 %."""
    envelope = np.maximum.accumulate(dev)
    k = len(dev)
    idx = np.arange(max(k // 5, 1), k)
    if len(idx) > 2 and envelope[idx[0]] > 0:
        slope = float(np.polyfit(np.log(idx + 1.0), np.log(envelope[idx]), 1)[0])
    else:
        slope = 0.0
    ratio = float(envelope[-1] / max(dev[0], 1e-300))
    if ratio > 1e3:
        growth = "growing"
    elif slope > 0.3:
        growth = f"growing algebraically (envelope ~ t^{slope:.1f})"
    else:
        growth = "bounded"
    return {"initial": float(dev[0]), "max_deviation": float(envelope[-1]),
            "growth_ratio": ratio, "envelope_exponent": slope, "growth": growth}

"""The smallest model that answers a scene, and its code specialised to the scene.

Selection (``choose``) looks at what the scene asks (``outputs``), whether contact is
possible, and the symmetry of the body and of the law:

* ``translational`` (2 states: Z_C, Z_C'): omega(0) = 0, the law satisfies (2.1) (C2.1,
  C2.3) and, if contact is possible, d = CS x n vanishes at every contact (C2.4);
* ``planar`` (4 states: Z_C, Z_C', kappa = K_z, phi): z = 0 in the law, omega(0) along
  z and, if contact is possible, the body z axis horizontal with S in the plane z = 0, so
  that d stays along z (E4.1, E4.2: omega_z in closed form from kappa);
* ``axisymmetric`` (2 states: psi, phi): free flight, J_x = J_y, x = y = 0 (E3.14);
* ``attitude`` (3 states): free flight and only omega or momentum asked;
* ``vertical`` (8 states): contact possible, the pose not asked;
* ``general`` (18 states) otherwise.

Specialisation substitutes the scene's numbers and its point law into the derived
specifications of :mod:`derive.models` before CSE; the function's inputs become
``(t, q)``.  Each model also knows how to rebuild the ``general`` layout (pose).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Callable

import numpy as np
import sympy as sp

from .. import models as dm
from .. import notation as nt
from .. import surfaces
from ..impact import lever
from ..reduced import axisymmetric, planar
from .geometry import lowest_point_numeric, momentum_frame, rotation_x, rotation_z
from .scene import Scene, SceneError, law_functions

T_VEC = dm.Vector("t", (nt.t,), ("t",))
POSE_OUTPUTS = {"pose"}


@dataclass
class SceneModel:
    kind: str
    why: str
    labels: tuple
    q0: np.ndarray
    specs: dict                      # rhs, and with contact: gap, impact, contact
    normalize: str                   # "matrix", "vector" or "none"
    z_index: int = -1
    zd_index: int = -1
    to_general: Callable | None = None     # (t, Q) -> (N, 18)
    omega_of: Callable | None = None       # (t, Q) -> (N, 3)
    generic_ops: int = 0
    extra: dict = field(default_factory=dict)

    @property
    def has_plane(self) -> bool:
        return "gap" in self.specs


# ---- substitutions ----------------------------------------------------------------------
def _float(x: float) -> sp.Float:
    return sp.Float(repr(float(x)), 17)


def number_subs(scene: Scene) -> dict:
    subs = {nt.M: _float(scene.M), nt.m: _float(scene.m), nt.J_x: _float(scene.J[0]),
            nt.J_y: _float(scene.J[1]), nt.J_z: _float(scene.J[2]), nt.g: _float(scene.g),
            nt.e: _float(scene.e)}
    return subs


MAX_MULTIPLE = 4


def share_harmonics(exprs: list) -> list:
    """Rewrite sin/cos of k t + c, for frequencies k that are small integer multiples
    n w0 of one base frequency, as polynomials in sin(w0 t), cos(w0 t) (``expand_trig``):
    one ``sincos`` per call instead of one per frequency.  Only multiples up to
    :data:`MAX_MULTIPLE` (coefficients <= 8, a few ulps of error), and only when there are
    at least two distinct frequencies; otherwise the expressions are returned unchanged."""
    from fractions import Fraction
    t = nt.t
    atoms = set()
    for e in exprs:
        atoms |= {a for a in sp.sympify(e).atoms(sp.sin, sp.cos)}
    freqs = {}
    for a in atoms:
        arg = sp.expand(a.args[0])
        k = arg.coeff(t)
        if not k.is_number or k == 0 or (arg - k * t).has(t):
            return exprs
        freqs[a] = (float(k), arg - k * t)
    distinct = sorted({abs(k) for k, _ in freqs.values()})
    if len(distinct) < 2:
        return exprs
    base = distinct[0]
    multiples = []
    for k in distinct:
        ratio = Fraction(k / base).limit_denominator(MAX_MULTIPLE)
        multiples.append(ratio)
    w0 = base / float(max(r.denominator for r in multiples))
    table = {}
    X = sp.Dummy("X")
    for a, (k, phase) in freqs.items():
        n = round(k / w0)
        if n == 0 or abs(n) > MAX_MULTIPLE or abs(k - n * w0) > 1e-14 * abs(k):
            return exprs
        expanded = sp.expand_trig(a.func(n * X + phase))
        base_arg = t if w0 == 1.0 else sp.Float(repr(w0), 17) * t
        table[a] = expanded.xreplace({X: base_arg})
    return [sp.sympify(e).xreplace(table) for e in exprs]


def law_parts(scene: Scene) -> tuple[dict, list]:
    """The point law: constant entries as substitutions, the others as definitions
    evaluated once per call (so that CSE shares them, as it shares the inputs ``u`` of
    the generic code)."""
    t = nt.t
    subs, definitions = {}, []
    syms_all, values_all = [], []
    for f, syms in zip(scene.law, ((nt.x, nt.xd, nt.xdd), (nt.y, nt.yd, nt.ydd),
                                   (nt.z, nt.zd, nt.zdd))):
        for sym, value in zip(syms, (f, sp.diff(f, t), sp.diff(f, t, 2))):
            syms_all.append(sym)
            values_all.append(sp.sympify(value))
    for sym, value in zip(syms_all, share_harmonics(values_all)):
        if value.free_symbols:
            definitions.append((sym, value))
        else:
            subs[sym] = sp.Float(value, 17) if not value.is_Integer else value
    return subs, definitions


def shape_subs(scene: Scene) -> dict:
    """OS and its rate as expressions in n (and omega) for the scene's shape."""
    if scene.shape == "none":
        return {}
    lp = surfaces.SHAPES[scene.shape]()
    geo = dict(zip(surfaces.center, (_float(c) for c in scene.center)))
    if scene.shape == "sphere":
        geo[surfaces.radius] = _float(scene.size[0])
    else:
        geo.update(zip(surfaces.semi_axes, (_float(a) for a in scene.size)))
    subs = dict(zip(nt.OS, lp.point.xreplace(geo)))
    subs.update(zip(nt.OS_rate, lp.rate.xreplace(geo)))
    return subs


def specialise(spec: dm.FunctionSpec, subs: dict, definitions: list, q: tuple,
               q_labels: tuple, name: str, outputs: list | None = None) -> dm.FunctionSpec:
    """``spec`` with ``subs`` applied everywhere and ``definitions`` (symbol, value)
    computed first; inputs ``(t, q)``; optionally new outputs ``[(name, exprs,
    labels)]`` written in the spec's symbols."""
    def sub(e):
        e = sp.sympify(e).xreplace(subs)
        return e.xreplace(subs)        # shape expressions bring symbols subs also maps

    outs = outputs if outputs is not None else [(v.name, v.entries, v.labels)
                                                for v in spec.outputs]
    solves = tuple(dm.LinearSolve(matrix=s.matrix.applyfunc(sub),
                                  rhs=tuple(r.applyfunc(sub) for r in s.rhs),
                                  unknowns=s.unknowns) for s in spec.solves)
    new_outputs = [dm.Vector(oname, tuple(sub(e) for e in exprs), labels)
                   for oname, exprs, labels in outs]
    defs = tuple((sym, sub(v)) for sym, v in definitions)
    defs += tuple((sym, sub(v)) for sym, v in spec.definitions)
    used = set()
    for vec in new_outputs:
        for v in vec.entries:
            used |= v.free_symbols
    for _, v in defs:
        used |= v.free_symbols
    solves = tuple(s for s in solves if any(sym in used for vec in s.unknowns for sym in vec))
    return dm.FunctionSpec(name=name, doc=spec.doc, inputs=(T_VEC, dm.Vector("q", q, q_labels)),
                           outputs=tuple(new_outputs), solves=solves, definitions=defs)


# ---- conditions of the reduced models ---------------------------------------------------------
def _law_samples(scene: Scene, n: int = 801):
    ts = np.linspace(scene.t0, scene.t0 + scene.duration, n)
    return ts, law_functions(scene)(ts)


def _translational_reason(scene: Scene) -> str | None:
    if any(w != 0.0 for w in scene.omega):
        return None
    ts, vals = _law_samples(scene)
    r, a = vals[[0, 3, 6]], vals[[2, 5, 8]]
    cross = np.cross(r.T, a.T)
    scale = max(np.max(np.linalg.norm(r, axis=0)) * np.max(np.linalg.norm(a, axis=0)), 1e-300)
    if np.max(np.abs(cross)) > 1e-12 * scale:
        return None
    why = "omega(0) = 0 and the law satisfies (2.1), OP x A_r = 0 (C2.1, C2.3)"
    if scene.contact_possible:
        n0 = scene.A0[2]
        rn = np.cross(r.T, n0)
        size = max(max(scene.size), np.max(np.linalg.norm(r, axis=0)), 1e-300)
        s0 = lowest_point_numeric(scene, n0)
        if np.max(np.abs(rn)) > 1e-12 * size or np.max(np.abs(np.cross(s0, n0))) > 1e-12 * size:
            return None
        why += "; P and S stay on the vertical through O, so d = 0 at impacts (C2.4)"
    return why


def _planar_reason(scene: Scene) -> str | None:
    if scene.omega[0] != 0.0 or scene.omega[1] != 0.0:
        return None
    if scene.law[2] != 0:
        return None
    why = "z = 0 in the law and omega(0) along z: omega_x = omega_y = 0 persists (E4.1)"
    if scene.contact_possible:
        if abs(scene.A0[2][2]) > 1e-12 or abs(scene.center[2]) > 1e-12:
            return None
        why += ("; the body z axis is horizontal and S lies in z = 0, so d stays along z "
                "through impacts and contact")
    return why


def _axisymmetric_reason(scene: Scene) -> str | None:
    if scene.contact_possible:
        return None
    if abs(scene.J[0] - scene.J[1]) > 1e-12 * max(scene.J):
        return None
    if scene.law[0] != 0 or scene.law[1] != 0:
        return None
    if all(w == 0.0 for w in scene.omega):
        return None
    return "free flight, J_x = J_y and P on the symmetry axis: quadratures (E3.11-E3.14)"


def choose(scene: Scene) -> tuple[str, str]:
    """The model and why (for ``model = "auto"``), or the forced one checked."""
    wants = set(scene.outputs)
    candidates = []
    tr = _translational_reason(scene)
    if tr:
        candidates.append(("translational", tr))
    pl = _planar_reason(scene)
    if pl:
        candidates.append(("planar", pl))
    ax = _axisymmetric_reason(scene)
    if ax:
        candidates.append(("axisymmetric", ax))
    if not scene.contact_possible and wants <= {"omega", "momentum"}:
        candidates.append(("attitude", "free flight and only omega/momentum asked: E1.7 alone"))
    if not wants & POSE_OUTPUTS:
        candidates.append(("vertical", "the pose is not asked: the horizontal motion of C is "
                                       "uniform and the heading is not needed"))
    candidates.append(("general", "the pose is asked and no symmetry reduces the model"
                       if wants & POSE_OUTPUTS else "no smaller model applies"))
    if scene.model == "auto":
        return candidates[0]
    for kind, why in candidates:
        if kind == scene.model:
            return kind, f"forced by [run].model; {why}"
    raise SceneError("[run].model", f"{scene.model!r} cannot answer this scene "
                                    f"(possible: {', '.join(k for k, _ in candidates)})")


# ---- the models -------------------------------------------------------------------------------
def _common(scene: Scene) -> tuple[dict, list]:
    subs = number_subs(scene)
    law_s, law_d = law_parts(scene)
    subs.update(law_s)
    subs.update(shape_subs(scene))
    return subs, law_d


def _contact_specs(model: str, subs: dict, defs: list, q, labels, pick=None):
    gap = dm.gap(model)
    imp = dm.impact(model)
    con = dm.contact_rhs(model)
    specs = {"gap": specialise(gap, subs, defs, q, labels, "gap")}
    if pick is None:
        specs["impact"] = specialise(imp, subs, defs, q, labels, "impact")
        specs["contact"] = specialise(
            con, subs, defs, q, labels, "contact",
            outputs=[(v.name, v.entries, v.labels) for v in con.outputs]
            + [("a_free", (_a_free(),), ("a_free",))])
    else:
        imp_out, con_out = pick
        specs["impact"] = specialise(imp, subs, defs, q, labels, "impact", outputs=imp_out)
        specs["contact"] = specialise(con, subs, defs, q, labels, "contact", outputs=con_out)
    return specs


@lru_cache(maxsize=None)
def _a_free():
    """dv_n/dt without reaction, in the contact spec's symbols (the free solution)."""
    from ..contact import contact_dynamics
    return contact_dynamics().a_free.xreplace(dict(zip(nt.omega_dot, dm.OMEGA_DOT_FREE)))


def _general_like(scene: Scene, model: str, why: str) -> SceneModel:
    subs, defs = _common(scene)
    q = dm.STATES[model]
    labels = dm.STATE_LABELS[model]
    specs = {"rhs": specialise(dm.flight_rhs(model), subs, defs, q, labels, "rhs")}
    if scene.contact_possible:
        specs.update(_contact_specs(model, subs, defs, q, labels))
    A0 = scene.A0
    if model == "general":
        q0 = np.r_[scene.com, scene.com_velocity, scene.omega, A0.reshape(-1)]
        z, zd, norm = 2, 5, "matrix"

        def to_general(t, Q):
            return Q
    elif model == "vertical":
        q0 = np.r_[scene.com[2], scene.com_velocity[2], scene.omega, A0[2]]
        z, zd, norm, to_general = 0, 1, "vector", None
    else:
        q0 = np.asarray(scene.omega, dtype=float)
        z, zd, norm, to_general = -1, -1, "none", None
    index = {lb: k for k, lb in enumerate(labels)}
    omega_idx = [index["omega_x"], index["omega_y"], index["omega_z"]]
    return SceneModel(kind=model, why=why, labels=labels, q0=q0, specs=specs,
                      normalize=norm, z_index=z, zd_index=zd, to_general=to_general,
                      omega_of=lambda t, Q: Q[:, omega_idx])


def _uniform_horizontal(scene: Scene, t):
    dt = np.asarray(t) - scene.t0
    X = scene.com[0] + scene.com_velocity[0] * dt
    Y = scene.com[1] + scene.com_velocity[1] * dt
    return X, Y, np.full_like(dt, scene.com_velocity[0]), np.full_like(dt, scene.com_velocity[1])


def _translational(scene: Scene, why: str) -> SceneModel:
    subs, defs = _common(scene)
    n0 = scene.A0[2]
    subs.update({nt.omega_x: 0, nt.omega_y: 0, nt.omega_z: 0,
                 **{w: 0 for w in nt.omega_dot}, **{w: 0 for w in nt.W},
                 **{w: 0 for w in dm.OMEGA_DOT_FREE},
                 **{nt.a[2, j]: _float(n0[j]) for j in range(3)}})
    q = (nt.Z_C, nt.Z_Cd)
    labels = ("Z_C", "Z_C'")
    flight = dm.flight_rhs("vertical")
    specs = {"rhs": specialise(flight, subs, defs, q, labels, "rhs",
                               outputs=[("dq", flight.outputs[0].entries[:2], labels)])}
    if scene.contact_possible:
        imp, con = dm.impact("vertical"), dm.contact_rhs("vertical")
        pick = ([("q_plus", imp.outputs[0].entries[:2], labels),
                 ("I", imp.outputs[1].entries, ("I",))],
                [("dq", con.outputs[0].entries[:2], labels),
                 ("N", con.outputs[1].entries, ("N",)), ("a_free", (_a_free(),), ("a_free",))])
        specs.update(_contact_specs("vertical", subs, defs, q, labels, pick=pick))
    A0 = scene.A0

    def to_general(t, Q):
        X, Y, VX, VY = _uniform_horizontal(scene, t)
        n = len(t)
        return np.column_stack([X, Y, Q[:, 0], VX, VY, Q[:, 1], np.zeros((n, 3)),
                                np.tile(A0.reshape(-1), (n, 1))])
    return SceneModel(kind="translational", why=why, labels=labels,
                      q0=np.array([scene.com[2], scene.com_velocity[2]]), specs=specs,
                      normalize="none", z_index=0, zd_index=1, to_general=to_general,
                      omega_of=lambda t, Q: np.zeros((len(t), 3)))


def _planar(scene: Scene, why: str) -> SceneModel:
    pl = planar()
    subs, defs = _common(scene)
    kappa, phi = pl.kappa, sp.Symbol("phi", real=True)
    A0 = scene.A0
    Rz = sp.Matrix([[sp.cos(phi), -sp.sin(phi), 0], [sp.sin(phi), sp.cos(phi), 0], [0, 0, 1]])
    n_of_phi = sp.Matrix([[_float(v) for v in A0[2]]]) * Rz
    # omega_z from kappa (E4.2) and n from phi, computed once per call
    omega_z = pl.omega_z
    defs = defs + [(nt.omega_z, omega_z)] + [(nt.a[2, j], n_of_phi[j]) for j in range(3)]
    subs.update({nt.omega_x: 0, nt.omega_y: 0})
    q = (nt.Z_C, nt.Z_Cd, kappa, phi)
    labels = ("Z_C", "Z_C'", "kappa", "phi")
    flight = dm.flight_rhs("vertical")
    specs = {"rhs": specialise(flight, subs, defs, q, labels, "rhs",
                               outputs=[("dq", (nt.Z_Cd, -nt.g, sp.Integer(0), nt.omega_z),
                                         labels)])}
    if scene.contact_possible:
        imp, con = dm.impact("vertical"), dm.contact_rhs("vertical")
        Kz = pl.K_z
        kappa_plus = Kz.xreplace({nt.omega_z: imp.outputs[0].entries[4]})
        _, d = lever()
        N_expr = con.outputs[1].entries[0]
        pick = ([("q_plus", (nt.Z_C, imp.outputs[0].entries[1], kappa_plus, phi), labels),
                 ("I", imp.outputs[1].entries, ("I",))],
                [("dq", (nt.Z_Cd, con.outputs[0].entries[1], N_expr * d[2],
                         nt.omega_z), labels),
                 ("N", (N_expr,), ("N",)), ("a_free", (_a_free(),), ("a_free",))])
        specs.update(_contact_specs("vertical", subs, defs, q, labels, pick=pick))
    law_values = dict(defs)
    law_values.update(subs)
    # kappa(0) from omega(0)
    def in_t(expr):
        """An expression of the law symbols and numbers as a function of t."""
        for _ in range(3):
            expr = sp.sympify(expr).xreplace(law_values)
        return expr.xreplace({nt.mu: nt.MU_DEFINITION}).xreplace(subs)
    Kz0 = sp.lambdify(nt.t, in_t(pl.K_z.xreplace(
        {nt.omega_z: _float(scene.omega[2])})), modules="numpy")
    q0 = np.array([scene.com[2], scene.com_velocity[2], float(Kz0(scene.t0)), 0.0])
    wz = sp.lambdify([nt.t, kappa], in_t(omega_z.xreplace({nt.mu: nt.MU_DEFINITION})),
                     modules="numpy")

    def omega_of(t, Q):
        w = np.broadcast_to(np.asarray(wz(t, Q[:, 2]), dtype=float), (len(t),))
        return np.column_stack([np.zeros(len(t)), np.zeros(len(t)), w])

    def to_general(t, Q):
        X, Y, VX, VY = _uniform_horizontal(scene, t)
        A = A0[None] @ rotation_z(Q[:, 3])
        return np.column_stack([X, Y, Q[:, 0], VX, VY, Q[:, 1], omega_of(t, Q),
                                A.reshape(len(t), 9)])
    return SceneModel(kind="planar", why=why, labels=labels, q0=q0, specs=specs,
                      normalize="none", z_index=0, zd_index=1, to_general=to_general,
                      omega_of=omega_of)


def _axisymmetric(scene: Scene, why: str) -> SceneModel:
    ax = axisymmetric()
    A0 = scene.A0
    w0 = np.asarray(scene.omega, dtype=float)
    r0 = law_functions(scene)(np.array([scene.t0]))[6, 0]
    Jeff0 = scene.J[0] + scene.mu * r0 ** 2
    K_body = np.array([Jeff0 * w0[0], Jeff0 * w0[1], scene.J[2] * w0[2]])
    K, R_K, psi0, theta0, phi0 = momentum_frame(A0 @ K_body, A0)
    subs, defs = _common(scene)
    from ..reduced import K_norm, omega_z0, phi, psi
    consts = {K_norm: _float(K), omega_z0: _float(w0[2])}
    psi_rate = ax.psi_rate.xreplace(consts)
    phi_rate = ax.phi_rate.xreplace(consts)
    q = (psi, phi)
    labels = ("psi", "phi")
    generic = dm.FunctionSpec(name="rhs", doc="axisymmetric quadratures (E3.14)",
                              inputs=(), outputs=(dm.Vector("dq", (psi_rate, phi_rate), labels),),
                              definitions=dm.MASS_DEFINITIONS)
    rhs = specialise(generic, subs, defs, q, labels, "rhs")
    law_values = dict(defs)

    def in_t(expr):
        for _ in range(3):
            expr = sp.sympify(expr).xreplace(law_values)
        return expr.xreplace({nt.mu: nt.MU_DEFINITION}).xreplace(subs)
    rates = sp.lambdify(nt.t, [in_t(psi_rate), in_t(phi_rate)], modules="numpy")
    sin0 = np.sin(theta0)

    def omega_of(t, Q):
        pd, _ = (np.broadcast_to(np.asarray(v, dtype=float), (len(t),)) for v in rates(t))
        ph = Q[:, 1]
        return np.column_stack([pd * sin0 * np.sin(ph), pd * sin0 * np.cos(ph),
                                np.full(len(t), w0[2])])

    def to_general(t, Q):
        X, Y, VX, VY = _uniform_horizontal(scene, t)
        dt = np.asarray(t) - scene.t0
        Z = scene.com[2] + scene.com_velocity[2] * dt - 0.5 * scene.g * dt ** 2
        VZ = scene.com_velocity[2] - scene.g * dt
        A = (R_K[None] @ rotation_z(Q[:, 0]) @ rotation_x(np.full(len(t), theta0))
             @ rotation_z(Q[:, 1]))
        return np.column_stack([X, Y, Z, VX, VY, VZ, omega_of(t, Q), A.reshape(len(t), 9)])
    return SceneModel(kind="axisymmetric", why=why, labels=labels, q0=np.array([psi0, phi0]),
                      specs={"rhs": rhs}, normalize="none", to_general=to_general,
                      omega_of=omega_of, extra={"K": K, "theta0": theta0, "R_K": R_K})


def build(scene: Scene) -> SceneModel:
    kind, why = choose(scene)
    if kind == "translational":
        model = _translational(scene, why)
    elif kind == "planar":
        model = _planar(scene, why)
    elif kind == "axisymmetric":
        model = _axisymmetric(scene, why)
    else:
        model = _general_like(scene, kind, why)
    model.generic_ops = 0
    return model


def generic_reference(kind: str) -> dm.FunctionSpec:
    """The generic RHS a specialised one is compared with (the general one for the
    reduced models that have no generic counterpart)."""
    return dm.flight_rhs(kind if kind in dm.MODELS else "general")



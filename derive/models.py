"""The models and their functions, as symbolic specifications for the emitters.

A :class:`FunctionSpec` lists named inputs (vectors of symbols), named outputs (vectors
of expressions) and the linear solves with ``J`` that the outputs need.  The unknowns of
a solve appear as symbols in the outputs; the generated code solves numerically, on the
matrix's numeric entries (the adjugate over the determinant, derive/emit/linalg.py),
never by a symbolic inverse.

State layouts: :mod:`derive.layout` (``a_ij = cos(fixed axis i, body axis j)``; row 3
is n in body axes); here each label gets its symbol:

* ``general`` (18): X_C, Y_C, Z_C, X_C', Y_C', Z_C', omega_x, omega_y, omega_z,
  a11, a12, a13, a21, a22, a23, a31, a32, a33
* ``vertical`` (8): Z_C, Z_C', omega_x, omega_y, omega_z, a31, a32, a33
* ``attitude`` (3): omega_x, omega_y, omega_z

Common inputs: ``u = (x, y, z, x', y', z', x'', y'', z'')`` (point law in body axes),
``p = (M, m, J_x, J_y, J_z, g)``, ``s = OS = (x*, y*, z*)``, restitution ``e``.
"""
from __future__ import annotations

import textwrap
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Callable

import sympy as sp

from . import layout
from . import notation as nt
from .impact import K_SYMBOL, V_N_MINUS, height, impact_map, lever
from .kinematics import poisson_equations
from .momentum import (MU_OP, flight_dynamics_euler, flight_dynamics_euler_scaled)
from .system import System
from . import shapes, surfaces


@dataclass(frozen=True)
class Vector:
    name: str
    entries: tuple            # symbols (inputs) or expressions (outputs)
    labels: tuple             # one name per entry, for documentation and CSV headers


@dataclass(frozen=True)
class LinearSolve:
    """``matrix @ unknowns[k] = rhs[k]`` for each k; ``matrix`` symmetric positive
    definite 3x3.  ``diagonal`` and ``rank_one = (a0, a1, a2, v0, v1, v2)``, when given,
    state ``matrix = diag(diagonal) - a v^T`` with ``a`` a multiple of ``v`` (E1.5's J:
    ``a = mu OP``, ``v = OP``, derive.momentum.flight_dynamics_euler), which a solver
    may use instead of the entries (derive.emit.linalg)."""
    matrix: sp.Matrix
    rhs: tuple
    unknowns: tuple
    diagonal: tuple = ()
    rank_one: tuple = ()

    @property
    def structure(self) -> tuple | None:
        """``(d0, d1, d2, a0, a1, a2, v0, v1, v2)`` or None."""
        return (*self.diagonal, *self.rank_one) if self.diagonal else None


@dataclass(frozen=True)
class FunctionSpec:
    name: str
    doc: str
    inputs: tuple
    outputs: tuple
    solves: tuple = ()
    definitions: tuple = ()   # ((symbol, expr), ...): named quantities computed first
    jacobian: bool = True     # generated/c carries its jac_ (derive.jacobians)

    def inlined(self, expr):
        """``expr`` with the definitions substituted (for references that want one
        expression in the inputs only)."""
        for sym, value in reversed(self.definitions):
            expr = expr.xreplace({sym: value})
        return expr

    def input(self, name: str) -> Vector:
        return next(v for v in self.inputs if v.name == name)

    def output(self, name: str) -> Vector:
        return next(v for v in self.outputs if v.name == name)


# ---- layouts ----------------------------------------------------------------------
A_FLAT = tuple(nt.a[i, j] for i in range(3) for j in range(3))
# the symbol of each state label (the labels and their order: derive/layout.py)
_SYMBOL = {"X_C": nt.X_C, "Y_C": nt.Y_C, "Z_C": nt.Z_C, "X_C'": nt.X_Cd, "Y_C'": nt.Y_Cd,
           "Z_C'": nt.Z_Cd, **dict(zip(layout.ATTITUDE.labels, nt.omega)),
           **dict(zip(layout.GENERAL.labels[layout.GENERAL.A], A_FLAT))}
STATE_LABELS = {model: layout.of(model).labels for model in ("general", "vertical", "attitude")}
STATES = {model: tuple(_SYMBOL[label] for label in labels)
          for model, labels in STATE_LABELS.items()}
U = (nt.x, nt.y, nt.z, nt.xd, nt.yd, nt.zd, nt.xdd, nt.ydd, nt.zdd)
U_LABELS = layout.U_LABELS
P = (nt.M, nt.m, nt.J_x, nt.J_y, nt.J_z, nt.g)
P_LABELS = ("M", "m", "J_x", "J_y", "J_z", "g")
S = tuple(nt.OS)
S_LABELS = ("x*", "y*", "z*")
MODELS = tuple(STATES)


def _q(model: str) -> Vector:
    return Vector("q", STATES[model], STATE_LABELS[model])


def _u() -> Vector:
    return Vector("u", U, U_LABELS)


def _p() -> Vector:
    return Vector("p", P, P_LABELS)


def _s() -> Vector:
    return Vector("s", S, S_LABELS)


def _e() -> Vector:
    return Vector("e", (nt.e,), ("e",))


# The derivation states the mass ratios as nu = m/(m+M) and mu = mM/(m+M) = M nu;
# emitted code takes M and m and computes these once, first.
MASS_DEFINITIONS = ((nt.nu, nt.MASS_FRACTION), (nt.mu, nt.M * nt.nu))
# ... and mu OP, which E1.5's J reads as a diagonal minus a rank-one term (inertia_solve)
INERTIA_DEFINITIONS = MASS_DEFINITIONS + tuple(zip(MU_OP, nt.mu * sp.Matrix(nt.OP)))


def _rates(model: str) -> dict:
    """Time derivative of each state symbol (omega' is the unknown of the solve)."""
    poisson = poisson_equations()
    rates = {nt.X_C: nt.X_Cd, nt.Y_C: nt.Y_Cd, nt.Z_C: nt.Z_Cd,
             nt.X_Cd: sp.Integer(0), nt.Y_Cd: sp.Integer(0), nt.Z_Cd: -nt.g}
    rates.update({w: wd for w, wd in zip(nt.omega, nt.omega_dot)})
    rates.update({nt.a[i, j]: poisson[i, j] for i in range(3) for j in range(3)})
    return rates


def euler_solve(form, unknowns: tuple = (nt.omega_dot,)) -> LinearSolve:
    """E1.7 in Euler's form (derive.momentum.flight_dynamics_euler) as a solve whose
    matrix is stated as a diagonal minus a rank-one term."""
    return LinearSolve(matrix=form.matrix, rhs=(form.forcing,), unknowns=unknowns,
                       diagonal=tuple(form.diagonal), rank_one=(*MU_OP, *form.vector))


def inertia_solve(rhs: tuple, unknowns: tuple) -> LinearSolve:
    """``J x = b`` for each right-hand side, E1.5's J stated as ``diag(J_i + mu |OP|^2) -
    (mu OP) OP^T`` (derive.momentum.flight_dynamics_euler; it reads mu OP from
    :data:`INERTIA_DEFINITIONS`)."""
    form = flight_dynamics_euler()
    return LinearSolve(matrix=form.matrix, rhs=rhs, unknowns=unknowns,
                       diagonal=tuple(form.diagonal), rank_one=(*MU_OP, *form.vector))


@dataclass(frozen=True)
class Family:
    """How a family of functions reads its system: the derivation's system (None: the
    paper's one point), the input ``u`` (the point's law, or the moments of
    derive/models_moments.py), the solve with J and the named quantities the solves and
    the other functions read.  ``prefix`` names the functions (None: by their model)."""
    prefix: str | None
    system: System | None
    u: Vector
    solve: Callable            # (rhs, unknowns) -> LinearSolve with J
    definitions: tuple         # read with the solves
    mass_definitions: tuple    # read without them

    def name(self, model: str, what: str) -> str:
        return f"{self.prefix or model}_{what}"

    def plain(self, what: str) -> str:
        """The name of a function of no model (``lie_stage``, ``moments_lie_stage``)."""
        return what if self.prefix is None else f"{self.prefix}_{what}"

    @property
    def own(self) -> str:
        """K - J omega, as the documentation writes it."""
        return "mu OP x V_r" if self.prefix is None else "k"


POINT = Family(prefix=None, system=None, u=_u(), solve=inertia_solve,
               definitions=INERTIA_DEFINITIONS, mass_definitions=MASS_DEFINITIONS)


@lru_cache(maxsize=None)
def flight_rhs(model: str) -> FunctionSpec:
    """``<model>_flight_rhs(q, u, p) -> dq``: E1.2, E1.7 (solved numerically), E1.8.
    E1.7 in Euler's form, times m + M (derive.momentum.flight_dynamics_euler_scaled)."""
    rates = _rates(model)
    dq = tuple(rates[s] for s in STATES[model])
    form = flight_dynamics_euler_scaled()
    solve = euler_solve(form)
    return FunctionSpec(
        name=f"{model}_flight_rhs",
        doc=f"Flight right-hand side of the {model} model: dq/dt (E1.2, E1.7 solved for "
            "omega', E1.8).",
        inputs=(_q(model), _u(), _p()),
        outputs=(Vector("dq", dq, tuple(f"d({lb})/dt" for lb in STATE_LABELS[model])),),
        solves=(solve,), definitions=MASS_DEFINITIONS + form.definitions)


@lru_cache(maxsize=None)
def flight_jacobian(model: str) -> FunctionSpec:
    """``<model>_flight_jacobian(q, u, p) -> A``: A = d(dq/dt)/dq, row-major, from the
    derived expressions.  Where dq/dt reads omega', solved from ``J omega' = F(q, u, p)``,
    ``d omega'/dq_k = X_k`` with ``J X_k = dF/dq_k``: J depends on u and p only, so these
    are further right-hand sides of the same closed-form solve (no inverse is formed)."""
    rhs = flight_rhs(model)
    (solve,) = rhs.solves
    (F,) = solve.rhs
    (unknown,) = solve.unknowns
    q = STATES[model]
    for sym in q:
        if any(sym in entry.free_symbols for entry in solve.matrix):
            raise ValueError(f"J depends on the state ({sym}): not this model's structure")
    X = [tuple(sp.symbols(f"X{k}_0:3", real=True)) for k in range(len(q))]
    entries = []
    for fi in rhs.outputs[0].entries:
        fi = sp.sympify(fi)
        coeffs = [fi.diff(w) for w in unknown]
        for k, qk in enumerate(q):
            entries.append(fi.diff(qk) + sum((c * x for c, x in zip(coeffs, X[k]) if c != 0),
                                             sp.Integer(0)))
    labels = STATE_LABELS[model]
    return FunctionSpec(
        name=f"{model}_flight_jacobian",
        doc=f"Jacobian of the {model} flight right-hand side with respect to the state, "
            "A[i*n + k] = d(dq_i/dt)/dq_k (E1.2, E1.7, E1.8 differentiated).",
        inputs=(_q(model), _u(), _p()),
        outputs=(Vector("A", tuple(entries),
                        tuple(f"d({a}')/d({b})" for a in labels for b in labels)),),
        solves=(replace(solve, rhs=tuple(F.diff(qk) for qk in q), unknowns=tuple(X)),),
        definitions=rhs.definitions)


@lru_cache(maxsize=None)
def impact(model: str, family: Family = POINT) -> FunctionSpec:
    """``<model>_impact(q, u, s, p, e) -> (q_plus, I)``: E1.11, E1.12, E1.15, E1.16."""
    if model == "attitude":
        raise ValueError("the attitude model has no contact geometry")
    im = impact_map(family.system)
    _, d = lever(family.system)
    impulse = im.impulse.xreplace({V_N_MINUS: im.normal_velocity, K_SYMBOL: im.k})
    after = {nt.X_Cd: nt.X_Cd + im.velocity_jump[0], nt.Y_Cd: nt.Y_Cd + im.velocity_jump[1],
             nt.Z_Cd: nt.Z_Cd + im.velocity_jump[2]}
    after.update({nt.omega[i]: im.omega_plus[i] for i in range(3)})
    q_plus = tuple(after.get(s, s) for s in STATES[model])
    outputs = (Vector("q_plus", q_plus, STATE_LABELS[model]),
               Vector("I", (nt.I,), ("I",)))
    # I itself is an intermediate: substitute it last so that CSE sees one impulse
    outputs = tuple(Vector(v.name, tuple(ex.xreplace({nt.I: impulse})
                                         for ex in v.entries), v.labels) for v in outputs)
    solve = family.solve((d,), (nt.W,))
    return FunctionSpec(
        name=family.name(model, "impact"),
        doc=f"Impact map of the {family.prefix or model} model: state just after the impact "
            "and the impulse I (E1.11, E1.12, E1.15, E1.16); apply only when v_n < 0.",
        inputs=(_q(model), family.u, _s(), _p(), _e()),
        outputs=outputs, solves=(solve,), definitions=family.definitions)


@lru_cache(maxsize=None)
def gap(model: str, family: Family = POINT) -> FunctionSpec:
    """``<model>_gap(q, u, s, p) -> (h, v_n)``: height of S and its rate (E1.14)."""
    if model == "attitude":
        raise ValueError("the attitude model has no contact geometry")
    h = height(family.system)
    v_n = impact_map(family.system).normal_velocity
    return FunctionSpec(
        name=family.name(model, "gap"),
        doc=f"Height h of the lowest point S above the plane and its rate v_n (E1.14), "
            f"{family.prefix or model} model.",
        inputs=(_q(model), family.u, _s(), _p()),
        outputs=(Vector("h", (h,), ("h",)), Vector("v_n", (v_n,), ("v_n",))),
        definitions=family.mass_definitions)


def _size_input(shape: str) -> Vector:
    """The size numbers a shape's functions read (derive.shapes): one field keeps its
    name (``radius``, ``semi_axes``), several are ``size``."""
    sh = shapes.of(shape)
    labels = tuple(lb for s in sh.sizes for lb in s.names(s.labels))
    name = sh.sizes[0].key if len(sh.sizes) == 1 else "size"
    return Vector(name, surfaces.shape_symbols(sh), labels)


@lru_cache(maxsize=None)
def lowest_point(shape: str) -> FunctionSpec:
    """``lowest_point_<shape>(n, center, size) -> s`` (size: derive.shapes)."""
    lp = surfaces.lowest_point(shape).point
    center = Vector("center", tuple(surfaces.center), ("c_x", "c_y", "c_z"))
    return FunctionSpec(
        name=f"lowest_point_{shape}",
        doc=f"Lowest point S of {shapes.with_article(shape)} (centre anywhere in the body) "
            "for the vertical n, body axes.",
        inputs=(Vector("n", tuple(nt.n), ("a31", "a32", "a33")), center, _size_input(shape)),
        outputs=(Vector("s", tuple(lp), S_LABELS),))


OMEGA_DOT_FREE = sp.Matrix(sp.symbols("omega_x'0 omega_y'0 omega_z'0", real=True))
SDOT = tuple(nt.OS_rate)
SDOT_LABELS = ("x*'", "y*'", "z*'")


@lru_cache(maxsize=None)
def contact_rhs(model: str, family: Family = POINT) -> FunctionSpec:
    """``<model>_contact_rhs(q, u, s, sdot, p) -> (dq, N)``: S held on the plane by the
    normal reaction N (derive.contact); valid while N >= 0."""
    if model == "attitude":
        raise ValueError("the attitude model has no contact geometry")
    from .contact import A_FREE, contact_dynamics
    cd = contact_dynamics(family.system)
    im = impact_map(family.system)
    f, d = cd.omega_rhs
    a_free = cd.a_free.xreplace(dict(zip(nt.omega_dot, OMEGA_DOT_FREE)))
    normal = cd.normal_force.xreplace({A_FREE: a_free, K_SYMBOL: im.k})
    omega_dot = OMEGA_DOT_FREE + nt.N * nt.W
    rates = _rates(model)
    rates[nt.Z_Cd] = cd.z_acceleration
    rates.update(dict(zip(nt.omega, omega_dot)))
    dq = tuple(sp.sympify(rates[s]).xreplace({nt.N: normal}) for s in STATES[model])
    solve = family.solve((f, d), (OMEGA_DOT_FREE, nt.W))
    return FunctionSpec(
        name=family.name(model, "contact_rhs"),
        doc=f"Persistent contact of the {family.prefix or model} model: dq/dt with S held on "
            "the plane and the normal reaction N (derive.contact); lift-off where N < 0.",
        inputs=(_q(model), family.u, _s(), Vector("sdot", SDOT, SDOT_LABELS), _p()),
        outputs=(Vector("dq", tuple(v for v in dq),
                        tuple(f"d({lb})/dt" for lb in STATE_LABELS[model])),
                 Vector("N", (normal,), ("N",))),
        solves=(solve,), definitions=family.definitions)


@lru_cache(maxsize=None)
def lowest_point_rate(shape: str) -> FunctionSpec:
    """``lowest_point_rate_<shape>(n, omega, size) -> sdot`` (the centre
    does not move in the body, so it does not enter)."""
    rate = surfaces.lowest_point(shape).rate
    base = lowest_point(shape)
    n_vec, _, size = base.inputs
    return FunctionSpec(
        name=f"lowest_point_rate_{shape}",
        doc=f"Rate of the lowest point S of {shapes.with_article(shape)} in body axes as the "
            "body turns (Poisson's equations for n).",
        inputs=(n_vec, Vector("omega", tuple(nt.omega), ("omega_x", "omega_y", "omega_z")),
                size),
        outputs=(Vector("sdot", tuple(rate), SDOT_LABELS),))


@lru_cache(maxsize=None)
def kinetic_moment(model: str, family: Family = POINT) -> FunctionSpec:
    """``<model>_kinetic_moment(q, u, p) -> K``: E1.6, body axes (|K| is E1.9's integral)."""
    from .momentum import angular_momentum
    K = tuple(k for k in angular_momentum(family.system).K)
    return FunctionSpec(
        name=family.name(model, "kinetic_moment"),
        doc=f"Angular momentum K about C in body axes (E1.6), {family.prefix or model} model.",
        inputs=(_q(model), family.u, _p()),
        outputs=(Vector("K", K, ("K_x", "K_y", "K_z")),),
        definitions=family.mass_definitions)


# ---- the momentum form (derive.momentum.momentum_form, derive.lie) -------------------------
def _A() -> Vector:
    return Vector("A", A_FLAT, tuple(f"a{i}{j}" for i in "123" for j in "123"))


def _omega() -> Vector:
    return Vector("omega", tuple(nt.omega), ("omega_x", "omega_y", "omega_z"))


@lru_cache(maxsize=None)
def momentum_omega(family: Family = POINT) -> FunctionSpec:
    """``momentum_omega(A, K, u, p) -> omega``: E1.4 solved for omega with K constant in
    fixed axes (E1.1): ``J omega = A^T K - mu OP x V_r``."""
    from .momentum import K_BODY, K_FIXED, momentum_form
    mf = momentum_form(family.system)
    seen = nt.a.T * K_FIXED
    rhs = mf.body_rhs.xreplace(dict(zip(K_BODY, seen)))
    return FunctionSpec(
        name=family.plain("momentum_omega" if family.prefix is None else "omega"),
        doc="omega of the momentum form: E1.4 solved with K constant in fixed axes "
            f"(E1.1), J omega = A^T K - {family.own}.",
        inputs=(_A(), Vector("K", tuple(K_FIXED), ("K_X", "K_Y", "K_Z")), family.u, _p()),
        outputs=(_omega(),),
        solves=(family.solve((rhs,), (nt.omega,)),),
        definitions=family.definitions)


@lru_cache(maxsize=None)
def fixed_kinetic_moment(family: Family = POINT) -> FunctionSpec:
    """``fixed_kinetic_moment(A, omega, u, p) -> K``: K about C in fixed axes, A K of
    E1.4 (the constant of a flight, E1.1)."""
    from .momentum import momentum_form
    return FunctionSpec(
        name=family.plain("fixed_kinetic_moment"),
        doc=f"K about C in fixed axes, A (J omega + {family.own}) (E1.4): constant in flight "
            "(E1.1).",
        inputs=(_A(), _omega(), family.u, _p()),
        outputs=(Vector("K", tuple(momentum_form(family.system).fixed),
                        ("K_X", "K_Y", "K_Z")),),
        definitions=family.mass_definitions)


def _W() -> Vector:
    return Vector("W", tuple(_lie().W), ("W_x", "W_y", "W_z"))


def _lie():
    from . import lie
    return lie


@lru_cache(maxsize=None)
def lie_stage(family: Family = POINT) -> FunctionSpec:
    """``lie_stage(W, k, u, p) -> (dW, omega)``: one stage of a Lie-group step.  With the
    attitude ``A = A_n exp(skew(W))`` and ``k = A_n^T K`` (K fixed, E1.1), the body
    components of K are ``exp(-skew(W)) k``; omega solves E1.4 with them, and
    ``W' = dexpinv(W, omega)`` is Poisson's E1.8 in exponential coordinates (derive.lie)."""
    from .momentum import K_BODY, momentum_form
    lie = _lie()
    ch = lie.exponential_chart()
    mf = momentum_form(family.system)
    series, values = ch.definitions()
    seen = ch.body_view(K_BODY, values=values)
    rhs = mf.body_rhs.xreplace(dict(zip(K_BODY, seen)))
    dW = ch.dexpinv(nt.omega, values=values)
    return FunctionSpec(
        name=family.plain("lie_stage"),
        doc="A stage of the Lie-group flight step: omega from E1.4 with K = exp(-W^) k in "
            "body axes, and W' = dexpinv(W, omega) (E1.8 in exponential coordinates).",
        inputs=(_W(), Vector("k", tuple(K_BODY), ("k_x", "k_y", "k_z")), family.u, _p()),
        outputs=(Vector("dW", tuple(dW), ("W_x'", "W_y'", "W_z'")), _omega()),
        solves=(family.solve((rhs,), (nt.omega,)),),
        definitions=family.definitions + series)


@lru_cache(maxsize=None)
def lie_point(family: Family = POINT) -> FunctionSpec:
    """``lie_point(W, k, u, p) -> (E, omega)``: the attitude factor ``exp(skew(W))`` of a
    point of a Lie step and omega there (E1.4 with K = E^T k): what the dense output of
    the momentum form needs at a time between steps."""
    from .momentum import K_BODY, momentum_form
    lie = _lie()
    ch = lie.exponential_chart()
    mf = momentum_form(family.system)
    series, values = ch.definitions()
    E = ch.exp_matrix(values=values)
    seen = E.T * K_BODY
    rhs = mf.body_rhs.xreplace(dict(zip(K_BODY, seen)))
    keep = {lie.S_W} | {sym for sym, _ in series if sym.name.startswith(("a_W", "b_W", "s_W"))}
    return FunctionSpec(
        name=family.plain("lie_point"),
        doc="exp(W^) and omega from E1.4 with K = exp(W^)^T k in body axes: a point of the "
            "dense output of a Lie-group flight step.",
        inputs=(_W(), Vector("k", tuple(K_BODY), ("k_x", "k_y", "k_z")), family.u, _p()),
        outputs=(Vector("E", tuple(E), tuple(f"e{i}{j}" for i in "123" for j in "123")),
                 _omega()),
        solves=(family.solve((rhs,), (nt.omega,)),),
        definitions=family.definitions + tuple((sym, v) for sym, v in series if sym in keep))


@lru_cache(maxsize=None)
def exp_map() -> FunctionSpec:
    """``exp_map(W) -> (E, quat)``: ``exp(skew(W))`` row-major and its unit quaternion
    (derive.lie; |W| <= derive.lie.THETA_MAX)."""
    lie = _lie()
    ch = lie.exponential_chart()
    series, values = ch.definitions()
    E = ch.exp_matrix(values=values)
    qw, qv = values[4], values[5]
    quat = (qw, qv * lie.W[0], qv * lie.W[1], qv * lie.W[2])
    return FunctionSpec(
        name="exp_map", doc="The exponential map of so(3): exp(W^) row-major and its unit "
                            "quaternion (w, x, y, z) (derive.lie, |W| <= 1.25).",
        inputs=(_W(),),
        outputs=(Vector("E", tuple(E), tuple(f"e{i}{j}" for i in "123" for j in "123")),
                 Vector("quat", quat, ("q_w", "q_x", "q_y", "q_z"))),
        definitions=series)


@lru_cache(maxsize=None)
def flight_parabola() -> FunctionSpec:
    """``flight_parabola(c, tau, p) -> c_tau``: C's position and velocity tau after the
    start of a flight (E1.2 integrated)."""
    from .momentum import TAU, flight_parabola as parabola
    position, velocity = parabola()
    labels = STATE_LABELS["general"][:6]
    return FunctionSpec(
        name="flight_parabola",
        doc="Position and velocity of C a time tau after the start of a flight (E1.2 "
            "integrated).",
        inputs=(Vector("c", STATES["general"][:6], labels), Vector("tau", (TAU,), ("tau",)),
                _p()),
        outputs=(Vector("c_tau", tuple(position) + tuple(velocity), labels),))


def momentum_specs() -> list[FunctionSpec]:
    return [momentum_omega(), fixed_kinetic_moment(), lie_stage(), lie_point(),
            flight_parabola(), exp_map()]


def all_specs() -> list[FunctionSpec]:
    specs = [flight_rhs(mdl) for mdl in MODELS]
    specs += [flight_jacobian(mdl) for mdl in MODELS]
    specs += [kinetic_moment(mdl) for mdl in MODELS]
    specs += [impact(mdl) for mdl in ("general", "vertical")]
    specs += [gap(mdl) for mdl in ("general", "vertical")]
    specs += [contact_rhs(mdl) for mdl in ("general", "vertical")]
    specs += [lowest_point(shape) for shape in shapes.SHAPE_NAMES]
    specs += [lowest_point_rate(shape) for shape in shapes.SHAPE_NAMES]
    specs += momentum_specs()
    return specs


def layout_doc() -> str:
    """The state layouts as documented in the README and the generated header."""
    lines = ["State layouts (a_ij = cos(fixed axis i, body axis j), so row 3 is the "
             "vertical n in body axes):"]
    for model in MODELS:
        lines.append(f"- {model}, {len(STATES[model])} states: "
                     f"({', '.join(STATE_LABELS[model])})")
    lines.append(f"Common inputs: u = ({', '.join(U_LABELS)}), the point's kinematics in "
                 "body axes; p = (M, m, J_x, J_y, J_z, g);")
    lines.append("s = OS = (x*, y*, z*), the lowest point in body axes; restitution e.")
    lines += textwrap.wrap(
        "moments_* functions (any number of points and rotors): the general state; u = "
        f"({', '.join(layout.MOMENTS_LABELS)}), the moments about O in body axes "
        "(derive/layout.py); p's m is the points' total mass.", width=88)
    return "\n".join(lines)


# ---- the runtime's models ------------------------------------------------------------------
# The C runtime (``generated/runtime/``) is compiled once per model and reads every number
# of a scene at run time.  Besides the functions above it needs the contact right-hand side
# with the free normal acceleration, and the closed forms of the reduced models.
@lru_cache(maxsize=None)
def runtime_contact(model: str, family: Family = POINT) -> FunctionSpec:
    """``contact_rhs`` with a third output, ``a_free`` = dv_n/dt without the reaction
    (the runtime compares it with 0 to tell resting from leaving); of the family's
    system (the moments': ``moments_contact_rhs_free``)."""
    from .contact import contact_dynamics
    base = contact_rhs(model, family)
    a_free = contact_dynamics(family.system).a_free.xreplace(
        dict(zip(nt.omega_dot, OMEGA_DOT_FREE)))
    return FunctionSpec(name=f"{base.name}_free", doc=base.doc + " Also a_free.",
                        inputs=base.inputs,
                        outputs=base.outputs + (Vector("a_free", (a_free,), ("a_free",)),),
                        solves=base.solves, definitions=base.definitions)


PLANAR_KAPPA = sp.Symbol("kappa", real=True)


@lru_cache(maxsize=None)
def planar_functions() -> tuple[FunctionSpec, FunctionSpec, FunctionSpec]:
    """The plane motion of E4.1/E4.2 (z = 0, omega = (0, 0, omega_z)): ``omega_z`` from
    the integral ``kappa = K_z`` (derive.reduced.planar), ``K_z`` from ``omega_z`` (after
    an impact), and ``d_z`` of the lever ``d = CS x n`` (dK_z/dt = N d_z in contact)."""
    from .reduced import planar
    pl = planar()
    _, d = lever()
    kappa = Vector("kappa", (pl.kappa,), ("kappa",))
    wz = Vector("omega_z", (nt.omega_z,), ("omega_z",))
    omega_z = FunctionSpec(
        name="planar_omega_z", doc="omega_z of the plane motion from K_z = kappa (E4.2).",
        inputs=(kappa, _u(), _p()), outputs=(Vector("omega_z", (pl.omega_z,), ("omega_z",)),),
        definitions=MASS_DEFINITIONS)
    K_z = FunctionSpec(
        name="planar_kappa", doc="K_z of the plane motion from omega_z (E4.2's integral).",
        inputs=(wz, _u(), _p()), outputs=(Vector("kappa", (pl.K_z,), ("kappa",)),),
        definitions=MASS_DEFINITIONS)
    lever_z = FunctionSpec(
        name="planar_lever_z", doc="d_z, the vertical body component of d = CS x n (E1.10).",
        inputs=(_q("vertical"), _u(), _s(), _p()), outputs=(Vector("d_z", (d[2],), ("d_z",)),),
        definitions=MASS_DEFINITIONS)
    return omega_z, K_z, lever_z


@lru_cache(maxsize=None)
def axisymmetric_rates() -> FunctionSpec:
    """``(psi', phi')`` of the axisymmetric carrier with P on its axis (E3.14), with the
    constants of the flight ``c = (|K|, omega_z0)``."""
    from .reduced import K_norm, axisymmetric, omega_z0
    ax = axisymmetric()
    return FunctionSpec(
        name="axisymmetric_rates", doc="psi' and phi' of E3.14 (J_x = J_y, x = y = 0).",
        inputs=(_u(), _p(), Vector("c", (K_norm, omega_z0), ("K", "omega_z0"))),
        outputs=(Vector("rates", (ax.psi_rate, ax.phi_rate), ("psi'", "phi'")),),
        definitions=MASS_DEFINITIONS)

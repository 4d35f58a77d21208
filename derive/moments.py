"""Internal motion as data: the carrier with any number of points and rotors, seen through
their moments about O (derive/layout.py's MOMENTS), derived from the definitions.

The bodies (body axes, O the carrier's centre of mass, ``J_O = diag(J_x, J_y, J_z)``):

* points j: mass ``m_j`` at ``rho_j = OP_j(t)``, a prescribed law;
* rotors k: symmetric about a unit axis ``a_k`` fixed in the body, axial moment ``I_k``,
  turning by ``psi_k(t)`` relative to the body, a prescribed law; a rotor's mass and its
  inertia as if locked are part of the carrier's (``M``, ``J_O``).

What a body contributes (:func:`point_share`, :func:`rotor_share`), from the definitions:

* a point, ``m rho x (d rho/dt)_abs = m rho x (rho' + omega x rho) = Theta_j omega + h_j``
  with ``Theta_j = m (|rho|^2 E - rho rho^T)`` and ``h_j = m rho x rho'``; its first moment
  ``s_j = m rho``; and their rates relative to the body;
* a rotor, its angular momentum about its centre ``I_r (omega + psi' a)`` with ``I_r =
  I_t E + (I - I_t) a a^T`` (any transverse ``I_t``): ``I_r omega`` (the locked part, in
  ``J_O``) plus ``I psi' a``, its share of h; nothing else (its centre moves with the body).

The moments are the sums: ``s``, ``Theta``, ``h`` and their rates; ``m = sum m_j``.  Then
K about C (:func:`moments_system`) from its definition, ``K = sum_i m_i (r_i - OC) x
(r_i - OC)'_abs + spins`` over the carrier, the points and the rotors, expanded per body
(:func:`_about_C`) and summed: ``sum_i m_i = m + M``, ``sum_i m_i r_i = s`` (O is the
carrier's centre), ``sum_i m_i r_i x r_i'_abs = J_O omega + Theta omega + h``; with ``OC =
s/(m + M)`` (the definition of C), ``K = J omega + k`` with

    J = J_O + Theta - (|s|^2 E - s s^T)/(m + M),      k = h - s x s'/(m + M).

For one point (:func:`one_point`) these are E1.4–E1.6 (``paper_checks``, X1.2).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp

from . import layout
from . import notation as nt
from .kinematics import absolute_rate_in_body_axes
from .momentum import flight_dynamics_structured
from .system import AngularMomentum, System

# ---- a point's and a rotor's symbols ----------------------------------------------------
m_j = sp.Symbol("m_j", positive=True)                      # a point's mass
ROTOR_AXIS = sp.Matrix(sp.symbols("a_x a_y a_z", real=True))   # unit, body axes
I_AXIAL = sp.Symbol("I_a", positive=True)                  # a rotor's axial moment
I_TRANSVERSE = sp.Symbol("I_t", positive=True)             # ... its transverse moment
psi_t = sp.Function("psi_r", real=True)(nt.t)              # its angle relative to the body
PSI_D, PSI_DD = sp.symbols("psi' psi''", real=True)

# the moments as the functions of derive/models_moments.py read them (layout.MOMENTS order)
MOMENTS = (*nt.s_m, *nt.s_md, *nt.s_mdd, *nt.upper(nt.Theta), *nt.upper(nt.Theta_d),
           *nt.h_m, *nt.h_md)
MOMENTS_T = (*nt.s_m_t, *(sp.Derivative(f, nt.t) for f in nt.s_m_t),
             *(sp.Derivative(f, (nt.t, 2)) for f in nt.s_m_t), *nt.upper(nt.Theta_t),
             *(sp.Derivative(f, nt.t) for f in nt.upper(nt.Theta_t)), *nt.h_m_t,
             *(sp.Derivative(f, nt.t) for f in nt.h_m_t))
# the chain rule of the moments: s -> s' -> s'', Theta -> Theta', h -> h'
MOMENTS_RATES = (*zip(nt.s_m, nt.s_md), *zip(nt.s_md, nt.s_mdd),
                 *zip(nt.upper(nt.Theta), nt.upper(nt.Theta_d)), *zip(nt.h_m, nt.h_md))
if len(MOMENTS) != layout.MOMENTS.nq or tuple(sp.Symbol(lb, real=True) for lb in
                                                layout.MOMENTS_LABELS) != MOMENTS:
    raise AssertionError("the moments' symbols differ from derive/layout.py's MOMENTS")


def _zero(expr) -> bool:
    """Zero as a rational function (the masses divide)."""
    return sp.expand(sp.numer(sp.together(sp.expand(expr)))) == 0


def _same(lhs, rhs, what: str):
    """``rhs`` after checking ``lhs == rhs`` entry by entry by expansion."""
    lhs, rhs = sp.Matrix(lhs), sp.Matrix(rhs)
    if not all(_zero(a - b) for a, b in zip(lhs, rhs)):
        raise AssertionError(f"{what}: the two sides differ")
    return rhs


def inertia_about(rho: sp.Matrix, mass) -> sp.Matrix:
    """``mass (|rho|^2 E - rho rho^T)``: a point's inertia about O."""
    return mass * (nt.dot(rho, rho) * sp.eye(3) - rho * rho.T)


@dataclass(frozen=True)
class Share:
    """One body's contribution to the moments, in the order of layout.MOMENTS (27
    expressions; a rotor's only in h and h')."""
    values: tuple
    inputs: tuple          # the symbols it reads

    def of(self, part: str) -> tuple:
        return self.values[getattr(layout.MOMENTS, part)]


@lru_cache(maxsize=None)
def point_share(mass=m_j) -> Share:
    """A point of mass ``mass`` on the law OP(t) (derive.notation's x(t), y(t), z(t)):
    ``s_j = m rho``, ``Theta_j``, ``h_j = m rho x rho'`` from the definition of its
    angular momentum about O, and their rates by differentiating (relative to the body)."""
    rho_t = nt.OP_t
    # the definition: m rho x (rho)'_abs, split into Theta_j omega + h_j
    about_O = mass * nt.cross(rho_t, absolute_rate_in_body_axes(rho_t))
    theta_t = inertia_about(rho_t, mass)
    h_t = mass * nt.cross(rho_t, rho_t.diff(nt.t))
    _same(nt.freeze(about_O), nt.freeze(theta_t * nt.omega_vec_t + h_t),
          "m rho x (rho' + omega x rho) = Theta_j omega + h_j")
    s_t = mass * rho_t
    values = [*s_t, *s_t.diff(nt.t), *s_t.diff(nt.t, 2), *nt.upper(theta_t),
              *nt.upper(theta_t.diff(nt.t)), *h_t, *h_t.diff(nt.t)]
    values = tuple(sp.expand(nt.freeze(v)) for v in values)
    if any(v.has(nt.t) for v in values):
        raise AssertionError("a point's share reads more than its law's jet")
    inputs = (nt.x, nt.y, nt.z, nt.xd, nt.yd, nt.zd, nt.xdd, nt.ydd, nt.zdd)
    return Share(values=values, inputs=inputs)


@lru_cache(maxsize=None)
def rotor_share() -> Share:
    """A rotor: its angular momentum about its centre is ``I_r (omega + psi' a)``; less
    the locked part ``I_r omega`` (counted in J_O) it is ``I psi' a`` whatever ``I_t``
    (``|a| = 1``); its rate relative to the body ``I psi'' a`` (the axis is fixed in the
    body)."""
    a = ROTOR_AXIS
    I_r = I_TRANSVERSE * sp.eye(3) + (I_AXIAL - I_TRANSVERSE) * a * a.T
    spin_t = I_r * (nt.omega_vec_t + psi_t.diff(nt.t) * a) - I_r * nt.omega_vec_t
    rates = {sp.Derivative(psi_t, (nt.t, 2)): PSI_DD, sp.Derivative(psi_t, nt.t): PSI_D}

    def on_unit_axis(lhs, rhs, what):
        """``rhs`` after checking that ``lhs - rhs`` vanishes where ``|a|^2 = 1`` (its
        remainder by ``|a|^2 - 1`` as a polynomial in a_z is zero)."""
        for c in (lhs - rhs).xreplace(rates):
            if sp.rem(sp.expand(c), nt.dot(a, a) - 1, a[2]) != 0:
                raise AssertionError(f"{what}: the two sides differ")
        return rhs

    h = on_unit_axis(spin_t, I_AXIAL * PSI_D * a, "I_r (omega + psi' a) - I_r omega = I psi' a")
    h_rate = on_unit_axis(spin_t.diff(nt.t), I_AXIAL * PSI_DD * a, "the rate of I psi' a")
    values = [sp.Integer(0)] * layout.MOMENTS.nq
    values[layout.MOMENTS.spin] = [*h, *h_rate]
    return Share(values=tuple(values), inputs=(*a, I_AXIAL, PSI_D, PSI_DD))


def _about_C(mass, r, c) -> sp.Matrix:
    """One body's ``mass (r - c) x (r - c)'_abs`` expanded by bilinearity: ``mass r x
    r'_abs - (mass r) x c'_abs - c x (mass r)'_abs + mass c x c'_abs`` (checked)."""
    rate = absolute_rate_in_body_axes
    direct = mass * nt.cross(r - c, rate(r - c))
    split = (mass * nt.cross(r, rate(r)) - nt.cross(mass * r, rate(c))
             - nt.cross(c, rate(mass * r)) + mass * nt.cross(c, rate(c)))
    _same(nt.freeze(direct), nt.freeze(split), "(r - c) x (r - c)' by bilinearity")
    return split


@lru_cache(maxsize=None)
def moments_system() -> System:
    """The carrier with any number of points and rotors: OC = s/(m+M) and K about C from
    its definition in terms of the moments (the module's docstring)."""
    M, m = nt.M, nt.m
    mass = m + M
    s_t, theta_t, h_t = nt.s_m_t, nt.Theta_t, nt.h_m_t
    oc_t = s_t / mass                                   # (m + M) OC = sum m_i r_i = s
    J_O = sp.diag(nt.J_x, nt.J_y, nt.J_z)
    w = nt.omega_vec_t
    rate = absolute_rate_in_body_axes
    # a generic body of the sums, to see that each sum is the moments' (one point's share
    # summed: sum m_i r_i x r_i'_abs = Theta omega + h, proved in point_share)
    point_share()
    _about_C(m_j, nt.OP_t, oc_t)
    # the sums of _about_C's four terms over the carrier (at O, own J_O omega), the points
    # and the rotors (their spins in h)
    K_t = (J_O * w + theta_t * w + h_t - nt.cross(s_t, rate(oc_t)) - nt.cross(oc_t, rate(s_t))
           + mass * nt.cross(oc_t, rate(oc_t)))
    K_def = nt.freeze(K_t)
    s, sd = nt.s_m, nt.s_md
    J = J_O + nt.Theta - (nt.dot(s, s) * sp.eye(3) - s * s.T) / mass
    own = nt.h_m - nt.cross(s, sd) / mass
    _same(K_def.jacobian(nt.omega), J, "dK/d omega = J_O + Theta - (|s|^2 E - s s^T)/(m+M)")
    _same(K_def - J * nt.omega, own, "K - J omega = h - s x s'/(m+M)")
    # factored for the code: J_O omega + Theta omega + h - OC x (s)'_abs
    K_vec = nt.freeze(J_O * w + theta_t * w + h_t - nt.cross(oc_t, rate(s_t)))
    _same(K_vec, K_def, "K = J_O omega + Theta omega + h - OC x s'_abs")
    momentum = AngularMomentum(K=J * nt.omega + own, J=J, own=own, K_definition=K_def,
                               K_vector=K_vec)
    return System(name="moments", oc=oc_t, momentum=momentum, law_rates=MOMENTS_RATES)


@lru_cache(maxsize=None)
def one_point() -> dict:
    """The moments of the paper's one point (mass m on OP): ``{moment symbol: value}``."""
    return dict(zip(MOMENTS, point_share(nt.m).values))


# ---- E1.7 of the moments, in Euler's form for the code --------------------------------------
OC = sp.Matrix(sp.symbols("OC_x OC_y OC_z", real=True))     # s/(m + M), named in the code


@dataclass(frozen=True)
class FlightForm:
    """``matrix omega' = forcing``, both reading the named :data:`OC` of ``definitions``."""
    matrix: sp.Matrix
    forcing: sp.Matrix
    definitions: tuple         # ((symbol, value), ...)

    def inline(self, expr):
        return expr.xreplace(dict(self.definitions))


@lru_cache(maxsize=None)
def flight_form() -> FlightForm:
    """The theorem of angular momentum applied to ``K = L - OC x U`` with ``L = J_O omega
    + Theta omega + h`` and ``U = s' + omega x s`` (the absolute rate of s, body axes;
    K_vector of :func:`moments_system`): E1.3 part by part, with ``OC' = s'/(m+M)`` and
    ``U' = s'' + omega' x s + omega x s'``,

        L' + omega x L - [OC' x U + OC x U' + omega x (OC x U)] = 0.

    The terms in omega' are ``J_O omega' + Theta omega' - OC x (omega' x s) = J omega'``.
    Of the rest, ``(m+M) OC' x U = s' x (omega x s)``, and by Jacobi's identity ``s' x
    (omega x s) + omega x (s x s') = s x (omega x s')``, so with ``OC x (omega x s')`` the
    three are ``2 OC x (omega x s') = 2 (OC.s') omega - 2 (OC.omega) s'``; and ``omega x
    (OC x (omega x s)) = -(OC.omega) omega x s``.  So

        J omega' = -omega x L - Theta' omega - h' + 2 (OC.s') omega
                   - (OC.omega) (2 s' + omega x s) + OC x s''

    (for one point: E1.7's Euler form of derive.momentum with mu = mM/(m+M)).  Checked
    against E1.3 applied to K as it stands (derive.momentum.flight_dynamics_structured)."""
    S = moments_system()
    w, s, sd, sdd = nt.omega, nt.s_m, nt.s_md, nt.s_mdd
    J_O = sp.diag(nt.J_x, nt.J_y, nt.J_z)
    L = J_O * w + nt.Theta * w + nt.h_m
    forcing = (-nt.cross(w, L) - nt.Theta_d * w - nt.h_md + 2 * nt.dot(OC, sd) * w
               - nt.dot(OC, w) * (2 * sd + nt.cross(w, s)) + nt.cross(OC, sdd))
    matrix = J_O + nt.Theta - (nt.dot(OC, s) * sp.eye(3) - OC * s.T)
    form = FlightForm(matrix=matrix, forcing=forcing,
                      definitions=tuple(zip(OC, s / (nt.m + nt.M))))
    fd = flight_dynamics_structured(S)
    _same(form.inline(forcing), fd.forcing, "the forcing in Euler's form")
    _same(form.inline(matrix), S.momentum.J, "the matrix")
    _same(fd.mass_matrix, S.momentum.J, "the coefficient of omega'")
    return form

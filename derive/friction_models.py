"""The rough plane's functions (:mod:`derive.friction`) as FunctionSpecs for the emitters.

``derive emit`` renders :func:`runtime_specs` into the rough model's runtime
(``generated/runtime/model_rough.c``; ``templates/runtime/crt_rough*.h``, ``crt_dk.h`` call them);
the tests render :func:`friction_specs` to C and CasADi the same way and compare both with
the NumPy evaluation and an independent Newton–Euler formulation
(``tests/test_friction_newton_euler.py``).

All for the ``general`` state (the slip of S needs the horizontal velocity of C and the
whole attitude, which the ``vertical`` model leaves out).  ``W`` is passed as its upper
triangle ``(W_XX, W_XY, W_XZ, W_YY, W_YZ, W_ZZ)`` (fixed axes); the Darboux–Keller state
along the normal impulse ``p`` is ``y = (v_X, v_Y, v_Z, P_X, P_Y, E_n, E_t)``: the
velocity of S, the tangential impulse, the work of the normal impulse and of friction.

* ``general_delassus(q, u, s, p) -> (W, v_S)``: W from three solves with J, and v_S.
* ``general_contact_velocity(q, u, s, p) -> v_S``: the velocity of S (fixed axes).
* ``impulse_slip_rate(y, W, mu_f) -> dy``: dy/dp while S slips (``v_t != 0``).
* ``impulse_slip_direction_rate(sigma, W, mu_f) -> dv``: dv/dp along a unit slip direction.
* ``impulse_stick_rate(y, W, mu_f) -> (dy, tau, margin)``: dy/dp while S sticks;
  ``margin = mu_f^2 - |tau|^2 >= 0`` iff stick is possible.
* ``impulse_resliding(W, mu_f, c) -> (sigma, f, df_dc)``: the ray ``sigma(c)`` and
  ``f = |sigma|^2 - 1``; Newton from ``c = 0`` finds the re-sliding ray.
* ``general_apply_impulse(q, u, s, p, P) -> q_plus``: the state after a total impulse
  P at S.
* ``general_sliding_rhs(q, u, s, sdot, p, mu_f, dir) -> (dq, N, v_t, a_t)``: sliding
  contact along the unit horizontal ``dir``.
* ``general_sticking_rhs(q, u, s, sdot, p) -> (dq, R)``: sticking contact and its
  reaction R.
* ``general_contact_wrench(q, u, s, sdot, p) -> (G, a_free, u_c, omega_free,
  omega_per_wrench)``: with spin friction or rolling resistance, the contact's
  velocities ``u = (v_S, A omega)`` change as ``du/dt = a_free + G (R, T)`` under the
  wrench (R, T) at S (G's upper triangle, row by row), and ``omega' = omega_free +
  omega_per_wrench (R, T)`` (its 3x6 matrix column by column); the runtime solves for the
  modes' unknowns on these numbers.
* ``general_wrench_rhs(q, u, s, p, w) -> dq``: the rates under a given wrench
  ``w = (R, T)`` at S (a solve with J; for the checks).
* ``general_wrench_rates(q, p, omega_dot, R) -> dq``: the same from omega', which the
  runtime forms from ``general_contact_wrench``'s ``omega_free`` and
  ``omega_per_wrench`` (no second solve).

The functions that read the system (``<family>_*``) come in two families: ``general``,
the paper's one point (``u`` its law), and ``moments``, any number of points and rotors
(``u`` their moments, derive/layout.py's MOMENTS; derive.moments), the same derivation of
derive.friction for each (:data:`FAMILIES`).  ``general_wrench_rates`` reads no ``u``: it
serves both.
"""
from __future__ import annotations

from functools import lru_cache

import sympy as sp

from . import friction as fr
from . import layout, moments
from . import notation as nt
from .models import (MASS_DEFINITIONS, SDOT, SDOT_LABELS, STATE_LABELS, STATES, FunctionSpec,
                     LinearSolve, Vector, _p, _q, _rates, _s, _u)
from .momentum import flight_dynamics_structured

MODEL = "general"
FAMILIES = ("general", "moments")


def _family(family: str):
    """``(system, u)``: the derivation's system (None: the paper's point) and the input
    ``u`` of a family of :data:`FAMILIES`."""
    if family == "general":
        return None, _u()
    if family == "moments":
        return (moments.moments_system(),
                Vector("u", moments.MOMENTS, layout.MOMENTS_LABELS))
    raise ValueError(f"no family {family!r}: one of {FAMILIES}")
Y_STATE = (*fr.V_S, *fr.P_T, fr.E_N, fr.E_T)
Y_LABELS = ("v_X", "v_Y", "v_Z", "P_X", "P_Y", "E_n", "E_t")
RHO = sp.Symbol("rho_t", nonnegative=True)       # |v_t|, the slip speed


def _W() -> Vector:
    return Vector("W", fr.W_UPPER, fr.W_LABELS)


def _mu() -> Vector:
    return Vector("mu_f", (fr.mu_f,), ("mu_f",))


def _y() -> Vector:
    return Vector("y", Y_STATE, Y_LABELS)


def _upper(matrix: sp.Matrix) -> tuple:
    return tuple(matrix[i, j] for i in range(3) for j in range(i, 3))


def _dq(rates: dict) -> Vector:
    dq = tuple(sp.sympify(rates[s]) for s in STATES[MODEL])
    return Vector("dq", dq, tuple(f"d({lb})/dt" for lb in STATE_LABELS[MODEL]))


@lru_cache(maxsize=None)
def delassus(family: str = "general") -> FunctionSpec:
    """``<family>_delassus(q, u, s, p) -> (W, v_S)``."""
    system, u = _family(family)
    dl = fr.delassus(system)
    fd = flight_dynamics_structured(system)
    return FunctionSpec(
        name=f"{family}_delassus",
        doc="Delassus matrix W of S (fixed axes, upper triangle): an impulse P at S changes "
            "the velocity of S by W P (derive.friction); and that velocity v_S.",
        inputs=(_q(MODEL), u, _s(), _p()),
        outputs=(Vector("W", _upper(dl.matrix), fr.W_LABELS),
                 Vector("v_S", tuple(fr.velocity_of_S(system)), ("v_X", "v_Y", "v_Z"))),
        solves=(LinearSolve(matrix=fd.mass_matrix, rhs=dl.rhs, unknowns=fr.Y),),
        definitions=MASS_DEFINITIONS)


@lru_cache(maxsize=None)
def contact_velocity(family: str = "general") -> FunctionSpec:
    """``<family>_contact_velocity(q, u, s, p) -> v_S``."""
    system, u = _family(family)
    return FunctionSpec(
        name=f"{family}_contact_velocity",
        doc="Velocity of the body point S, fixed axes (its Z component is E1.14's v_n; "
            "X and Y are the slip velocity).",
        inputs=(_q(MODEL), u, _s(), _p()),
        outputs=(Vector("v_S", tuple(fr.velocity_of_S(system)), ("v_X", "v_Y", "v_Z")),),
        definitions=MASS_DEFINITIONS)


@lru_cache(maxsize=None)
def impulse_slip_rate() -> FunctionSpec:
    """``impulse_slip_rate(y, W, mu_f) -> dy``: Darboux–Keller while S slips."""
    dk = fr.darboux_keller()
    sigma = dict(zip(fr.SIGMA, (fr.V_S[0] / RHO, fr.V_S[1] / RHO)))
    dy = (*dk.slip_rate, -fr.mu_f * fr.SIGMA[0], -fr.mu_f * fr.SIGMA[1], fr.V_S[2],
          -fr.mu_f * RHO)
    definitions = ((RHO, sp.sqrt(fr.V_S[0] ** 2 + fr.V_S[1] ** 2)), *sigma.items())
    return FunctionSpec(
        name="impulse_slip_rate",
        doc="Darboux-Keller rate dy/dp in the normal impulse p while S slips (|v_t| > 0): "
            "dv/dp = W (e_Z - mu_f v_t/|v_t|) (derive.friction).",
        inputs=(_y(), _W(), _mu()),
        outputs=(Vector("dy", dy, tuple(f"d({lb})/dp" for lb in Y_LABELS)),),
        definitions=definitions)


@lru_cache(maxsize=None)
def impulse_slip_direction_rate() -> FunctionSpec:
    """``impulse_slip_direction_rate(sigma, W, mu_f) -> dv``: the slip's rates along a
    unit direction (the polar form of the slip stage and its rays)."""
    dk = fr.darboux_keller()
    return FunctionSpec(
        name="impulse_slip_direction_rate",
        doc="Darboux-Keller rate dv/dp = W (e_Z - mu_f sigma) of the velocity of S while it "
            "slips along the unit direction sigma (derive.friction).",
        inputs=(Vector("sigma", tuple(fr.SIGMA), ("sigma_X", "sigma_Y")), _W(), _mu()),
        outputs=(Vector("dv", tuple(dk.slip_rate), ("d(v_X)/dp", "d(v_Y)/dp", "d(v_Z)/dp")),))


@lru_cache(maxsize=None)
def impulse_stick_rate() -> FunctionSpec:
    """``impulse_stick_rate(y, W, mu_f) -> (dy, tau, margin)``: while S sticks."""
    dk = fr.darboux_keller()
    tau = dk.stick_tau_by_z
    dy = (*dk.stick_rate, tau[0], tau[1], fr.V_S[2], sp.Integer(0))
    return FunctionSpec(
        name="impulse_stick_rate",
        doc="Darboux-Keller rate dy/dp while S sticks (v_t = 0): the tangential impulse "
            "rate tau = z_t/z_Z with W z = e_Z keeps v_t = 0; stick is possible iff "
            "margin = mu_f^2 - |tau|^2 >= 0 (derive.friction).",
        inputs=(_y(), _W(), _mu()),
        outputs=(Vector("dy", dy, tuple(f"d({lb})/dp" for lb in Y_LABELS)),
                 Vector("tau", tuple(tau), ("tau_X", "tau_Y")),
                 Vector("margin", (dk.stick_margin,), ("margin",))),
        solves=(LinearSolve(matrix=fr.W_SYM, rhs=(sp.Matrix([0, 0, 1]),),
                            unknowns=(fr.Z_STICK,)),))


@lru_cache(maxsize=None)
def impulse_resliding() -> FunctionSpec:
    """``impulse_resliding(W, mu_f, c) -> (sigma, f, df_dc)``."""
    dk = fr.darboux_keller()
    f = dk.ray_residual
    return FunctionSpec(
        name="impulse_resliding",
        doc="Re-sliding when stick is impossible: sigma(c) = (c + mu_f W_tt)^-1 W_tn (2x2 "
            "closed form on the numbers W) and f(c) = |sigma(c)|^2 - 1, convex and "
            "decreasing for c > 0: Newton's method from c = 0 finds the ray's rate c, "
            "sigma(c) its direction (derive.friction).",
        inputs=(_W(), _mu(), Vector("c", (fr.C_RAY,), ("c",))),
        outputs=(Vector("sigma", tuple(dk.ray_direction), ("sigma_X", "sigma_Y")),
                 Vector("f", (f,), ("f",)),
                 Vector("df_dc", (sp.diff(f, fr.C_RAY),), ("df/dc",))))


OMEGA_JUMP = sp.Matrix(sp.symbols("domega_x domega_y domega_z", real=True))


@lru_cache(maxsize=None)
def apply_impulse(family: str = "general") -> FunctionSpec:
    """``<family>_apply_impulse(q, u, s, p, P) -> q_plus``."""
    system, u = _family(family)
    dl = fr.delassus(system)
    fd = flight_dynamics_structured(system)
    after = {v: v + dv for v, dv in zip(nt.V_C, dl.velocity_jump)}
    after.update({w: w + dw for w, dw in zip(nt.omega, OMEGA_JUMP)})
    q_plus = tuple(after.get(s, s) for s in STATES[MODEL])
    return FunctionSpec(
        name=f"{family}_apply_impulse",
        doc="State just after an impact whose total impulse at S is P (fixed axes): "
            "V_C + P/(m+M), omega + J^-1 (CS x A^T P) (derive.friction).",
        inputs=(_q(MODEL), u, _s(), _p(), Vector("P", tuple(fr.P_IMP), ("P_X", "P_Y", "P_Z"))),
        outputs=(Vector("q_plus", q_plus, STATE_LABELS[MODEL]),),
        solves=(LinearSolve(matrix=fd.mass_matrix, rhs=(dl.moment,), unknowns=(OMEGA_JUMP,)),),
        definitions=MASS_DEFINITIONS)


@lru_cache(maxsize=None)
def sliding_rhs(family: str = "general") -> FunctionSpec:
    """``<family>_sliding_rhs(q, u, s, sdot, p, mu_f, dir) -> (dq, N, v_t, a_t)``."""
    system, u = _family(family)
    sc = fr.sliding_contact(system)
    fd = flight_dynamics_structured(system)
    N = sc.normal_force
    rates = _rates(MODEL)
    rates.update(dict(zip(nt.V_C, sc.acc_C)))
    rates.update(dict(zip(nt.omega, sc.omega_dot)))
    rates = {k: sp.sympify(v).xreplace({nt.N: N}) for k, v in rates.items()}
    v_t = tuple(fr.velocity_of_S(system)[:2])
    a_t = tuple(c.xreplace({nt.N: N}) for c in sc.slip_acceleration)
    return FunctionSpec(
        name=f"{family}_sliding_rhs",
        doc="Sliding contact: S on the plane slipping along the unit horizontal dir, "
            "reaction N (e_Z - mu_f dir) with N from dv_n/dt = 0 (derive.friction); also "
            "the slip velocity v_t and its rate a_t.  Valid while N >= 0 and v_t != 0.",
        inputs=(_q(MODEL), u, _s(), Vector("sdot", SDOT, SDOT_LABELS), _p(), _mu(),
                Vector("dir", tuple(fr.SIGMA), ("dir_X", "dir_Y"))),
        outputs=(_dq(rates), Vector("N", (N,), ("N",)), Vector("v_t", v_t, ("v_X", "v_Y")),
                 Vector("a_t", a_t, ("v_X'", "v_Y'"))),
        solves=(LinearSolve(matrix=fd.mass_matrix, rhs=(sc.forcing, sc.lever),
                            unknowns=(fr.OMEGA_DOT_0, fr.W_SLIDE)),),
        definitions=MASS_DEFINITIONS)


@lru_cache(maxsize=None)
def sticking_rhs(family: str = "general") -> FunctionSpec:
    """``<family>_sticking_rhs(q, u, s, sdot, p) -> (dq, R)``."""
    system, u = _family(family)
    st = fr.sticking_contact(system)
    dl = fr.delassus(system)
    fd = flight_dynamics_structured(system)
    rates = _rates(MODEL)
    rates.update(dict(zip(nt.V_C, st.acc_C)))
    rates.update(dict(zip(nt.omega, st.omega_dot)))
    return FunctionSpec(
        name=f"{family}_sticking_rhs",
        doc="Sticking contact: S at rest on the plane, held by the reaction R (fixed axes) "
            "from dv_S/dt = 0, a solve with the Delassus matrix W (derive.friction).  "
            "Valid while R_Z >= 0 and R_X^2 + R_Y^2 <= mu_f^2 R_Z^2.",
        inputs=(_q(MODEL), u, _s(), Vector("sdot", SDOT, SDOT_LABELS), _p()),
        outputs=(_dq(rates), Vector("R", tuple(fr.R_VEC), ("R_X", "R_Y", "R_Z"))),
        solves=(LinearSolve(matrix=fd.mass_matrix, rhs=(st.forcing, *dl.rhs),
                            unknowns=(fr.OMEGA_DOT_0, *fr.Y)),
                LinearSolve(matrix=st.matrix, rhs=(-st.a_free,), unknowns=(fr.R_VEC,))),
        definitions=MASS_DEFINITIONS)


def _upper6(matrix: sp.Matrix) -> tuple:
    return tuple(matrix[i, j] for i in range(6) for j in range(i, 6))


G_LABELS = tuple(f"G_{i}{j}" for i in range(6) for j in range(i, 6))


@lru_cache(maxsize=None)
def contact_wrench(family: str = "general") -> FunctionSpec:
    """``<family>_contact_wrench(q, u, s, sdot, p) -> (G, a_free, u_c)``."""
    system, u = _family(family)
    cw = fr.contact_wrench(system)
    fd = flight_dynamics_structured(system)
    return FunctionSpec(
        name=f"{family}_contact_wrench",
        doc="The contact as a wrench (R, T) at S (derive.friction.contact_wrench): the "
            "velocity of S and the angular velocity (fixed axes), u, change as du/dt = "
            "a_free + G (R, T); G's upper triangle row by row, a_free and u (u_c).",
        inputs=(_q(MODEL), u, _s(), Vector("sdot", SDOT, SDOT_LABELS), _p()),
        outputs=(Vector("G", _upper6(cw.matrix), G_LABELS),
                 Vector("a_free", tuple(cw.a_free), tuple(f"d({lb})/dt" for lb in
                                                          fr.RATE_LABELS)),
                 Vector("u_c", tuple(cw.velocity), fr.RATE_LABELS),
                 Vector("omega_free", tuple(fr.OMEGA_DOT_0), ("omega_x'0", "omega_y'0",
                                                              "omega_z'0")),
                 Vector("omega_per_wrench", tuple(c for col in (*fr.Y, *fr.YT) for c in col),
                        tuple(f"d(omega_{a}')/d{w}" for w in fr.WRENCH_LABELS
                              for a in "xyz"))),
        solves=(LinearSolve(matrix=fd.mass_matrix, rhs=(fd.forcing, *cw.rhs),
                            unknowns=(fr.OMEGA_DOT_0, *fr.Y, *fr.YT)),),
        definitions=MASS_DEFINITIONS)


@lru_cache(maxsize=None)
def wrench_rhs(family: str = "general") -> FunctionSpec:
    """``<family>_wrench_rhs(q, u, s, p, w) -> dq``."""
    system, u = _family(family)
    cw = fr.contact_wrench(system)
    fd = flight_dynamics_structured(system)
    rates = _rates(MODEL)
    rates.update(dict(zip(nt.V_C, cw.acc_C)))
    rates.update(dict(zip(nt.omega, fr.OMEGA_DOT_W)))
    return FunctionSpec(
        name=f"{family}_wrench_rhs",
        doc="Contact under a given wrench w = (R, T) at S (fixed axes): dq/dt with "
            "V_C' = R/(m+M) - g e_Z and J omega' = f + CS x A^T R + A^T T "
            "(derive.friction.contact_wrench).",
        inputs=(_q(MODEL), u, _s(), _p(), Vector("w", tuple(fr.WRENCH),
                                                     fr.WRENCH_LABELS)),
        outputs=(_dq(rates),),
        solves=(LinearSolve(matrix=fd.mass_matrix, rhs=(fd.forcing + cw.moment,),
                            unknowns=(fr.OMEGA_DOT_W,)),),
        definitions=MASS_DEFINITIONS)


@lru_cache(maxsize=None)
def wrench_rates() -> FunctionSpec:
    """``general_wrench_rates(q, p, omega_dot, R) -> dq``."""
    cw = fr.contact_wrench()
    rates = _rates(MODEL)
    rates.update(dict(zip(nt.V_C, cw.acc_C)))
    rates.update(dict(zip(nt.omega, fr.OMEGA_DOT_W)))
    return FunctionSpec(
        name="general_wrench_rates",
        doc="Contact under a wrench whose omega' is known (omega'_0 + sum R_k Y_k + sum "
            "T_k YT_k, from general_contact_wrench's omega_free and omega_per_wrench): dq/dt "
            "with V_C' = R/(m+M) - g e_Z (derive.friction.contact_wrench); no solve.",
        inputs=(_q(MODEL), _p(), Vector("omega_dot", tuple(fr.OMEGA_DOT_W),
                                         ("omega_x'", "omega_y'", "omega_z'")),
                Vector("R", tuple(fr.R_VEC), ("R_X", "R_Y", "R_Z"))),
        outputs=(_dq(rates),),
        definitions=MASS_DEFINITIONS)


def runtime_specs(family: str = "general") -> list[FunctionSpec]:
    """What a rough model's runtime calls (templates/runtime/model.c.jinja, crt_rough*.h
    and the Darboux-Keller step of crt_rk_steps.h; the slip stage in polar form reads
    impulse_slip_direction_rate, not impulse_slip_rate): the family's functions (the
    rough model's general ones, the moments_rough model's moments ones) and those of W, or
    of omega' and R, alone."""
    return [delassus(family), contact_velocity(family), impulse_slip_direction_rate(),
            impulse_stick_rate(), impulse_resliding(), apply_impulse(family),
            sliding_rhs(family), sticking_rhs(family), contact_wrench(family),
            wrench_rates()]


def friction_specs() -> list[FunctionSpec]:
    return [delassus(), contact_velocity(), impulse_slip_rate(), impulse_slip_direction_rate(),
            impulse_stick_rate(), impulse_resliding(), apply_impulse(), sliding_rhs(),
            sticking_rhs(), contact_wrench(), wrench_rhs(), wrench_rates()]


def family_specs(family: str) -> list[FunctionSpec]:
    """The functions that read the system, for one family of :data:`FAMILIES` (the others
    work on W alone, or, general_wrench_rates, on omega' and R)."""
    return [delassus(family), contact_velocity(family), apply_impulse(family),
            sliding_rhs(family), sticking_rhs(family), contact_wrench(family),
            wrench_rhs(family)]

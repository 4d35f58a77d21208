"""Checks of internal motion as data (``EXTENSIONS.md``, X2): the carrier with any number
of points and rotors, seen through their moments (derive/moments.py), derived once with
the paper's derivation (derive.system), and the paper's equations as its one-point case.

X1.2: the moments form from the definitions, for an explicit system (two points and a
rotor on its own axis): K about C summed body by body equals ``J omega + k`` with the
moments summed from the emitted shares (point_moments, rotor_moments), and J is the
inertia about C as if locked (so positive definite).

X1.3–X1.5: the moments of one point of mass m (``s = m OP``, ``Theta = m (|OP|^2 E - OP
OP^T)``, ``h = m OP x OP'`` and their rates) put into the moments' derivation give the
paper's: E1.4–E1.9 (X1.3), E1.10–E1.16 (X1.4), and the persistent contact and the rough
plane of derive/contact.py and derive/friction.py (X1.5), compared with the one-point
derivation and, where the paper prints them, with the printed forms.  The derivations are
read through their modules so that a test can break one and see the check fail.
"""
from __future__ import annotations

import sympy as sp

from derive import contact, friction as fr, impact, momentum
from derive import moments as mm
from derive import notation as nt

from . import printed as P
from .exact import LinearDefinition, assert_numeric, assert_same, assert_zero
from .registry import Report, check

W_IS_JINV_D = LinearDefinition(nt.W, P.E1_5.xreplace({nt.mu: P.MU}), P.E1_10_D)


def _one_point(expr):
    """An expression of the moments' derivation with the one point's moments put in."""
    return expr.xreplace(mm.one_point())


def _paper(expr):
    return nt.from_paper_notation(expr)


# ---- X1.2: an explicit system -------------------------------------------------------------
def _explicit_system():
    """Two points (masses m_1, m_2, laws rho_1(t), rho_2(t)) and a rotor of axial moment
    I_a about the unit axis a = (2, 3, 6)/7 through G, turning by psi(t); the rotor's mass
    m_r and central inertia I_r (any transverse I_t) are part of the carrier's M and
    J_O.  Returns (K about C as time functions, the frozen symbols' table, the moments
    from the shares, m, the laws)."""
    t = nt.t
    masses = sp.symbols("m_1 m_2", positive=True)
    laws = [sp.Matrix([sp.Function(f"{c}_{k}", real=True)(t) for c in "xyz"]) for k in (1, 2)]
    psi = sp.Function("psi", real=True)(t)
    a = sp.Matrix([2, 3, 6]) / 7
    G = sp.Matrix(sp.symbols("G_x G_y G_z", real=True))
    m_r, I_a, I_t = sp.symbols("m_r I_a I_t", positive=True)
    I_r = I_t * sp.eye(3) + (I_a - I_t) * a * a.T
    J_O = sp.diag(nt.J_x, nt.J_y, nt.J_z)
    w = nt.omega_vec_t

    def rate(b):
        return b.diff(t) + nt.cross(w, b)

    total = nt.M + sum(masses)
    c = sum((mj * rj for mj, rj in zip(masses, laws)), sp.zeros(3, 1)) / total
    # the carrier (the rotor locked in it): J_O less the rotor's inertia about O, then the
    # rotor's mass at G moving with the body and its own angular momentum about G
    rigid = J_O - I_r - m_r * (G.dot(G) * sp.eye(3) - G * G.T)
    about_O = rigid * w + m_r * nt.cross(G, nt.cross(w, G)) + I_r * (w + psi.diff(t) * a)
    K = about_O + nt.M * nt.cross(-c, rate(-c))
    for mj, rj in zip(masses, laws):
        K += mj * nt.cross(rj - c, rate(rj - c))
    # frozen symbols of the laws: the k-th point's x, x', x'' ...
    table, point_syms = {}, []
    for k, rj in enumerate(laws, start=1):
        syms = {}
        for c_, f in zip("xyz", rj):
            s0, s1, s2 = sp.symbols(f"{c_}_{k} {c_}_{k}' {c_}_{k}''", real=True)
            table[f.diff(t, 2)], table[f.diff(t)], table[f] = s2, s1, s0
            syms[c_] = (s0, s1, s2)
        point_syms.append(syms)
    table[psi.diff(t, 2)], table[psi.diff(t)] = mm.PSI_DD, mm.PSI_D
    # the moments: the sum of the emitted shares
    moments = sp.zeros(len(mm.MOMENTS), 1)
    for mj, syms in zip(masses, point_syms):
        rename = {}
        for c_, (s0, s1, s2) in syms.items():
            x0, x1, x2 = {"x": (nt.x, nt.xd, nt.xdd), "y": (nt.y, nt.yd, nt.ydd),
                          "z": (nt.z, nt.zd, nt.zdd)}[c_]
            rename.update({x0: s0, x1: s1, x2: s2})
        moments += sp.Matrix(mm.point_share(mj).values).xreplace(rename)
    moments += sp.Matrix(mm.rotor_share().values).xreplace(
        {**dict(zip(mm.ROTOR_AXIS, a)), mm.I_AXIAL: I_a})
    K_frozen = nt.freeze(K.xreplace(table))
    return K_frozen, dict(zip(mm.MOMENTS, moments)), sum(masses), masses, laws, table, c


@check("X1.2")
def x2_1(r: Report) -> None:
    K, moments, m_total, masses, laws, table, c = _explicit_system()
    S = mm.moments_system()
    on = {**moments, nt.m: m_total}
    assert_zero("X1.2 K about C summed body by body - (J omega + k)",
                K - S.momentum.K.xreplace(on))
    # J is the inertia about C of the locked system: J_O, the carrier's mass at O and the
    # points, each about C; so v^T J v > 0 for v != 0 when J_O is positive definite
    v = sp.Matrix(sp.symbols("v_1:4", real=True))
    cz = nt.freeze(c.xreplace(table))
    rel = [-cz] + [nt.freeze(rj.xreplace(table)) - cz for rj in laws]
    quad = (v.T * sp.diag(nt.J_x, nt.J_y, nt.J_z) * v)[0]
    for mass, rr in zip((nt.M, *masses), rel):
        cr = nt.cross(rr, v)
        quad += mass * (cr.T * cr)[0]
    assert_zero("X1.2 v^T J v - v^T J_O v - sum m |(r - OC) x v|^2",
                (v.T * S.momentum.J.xreplace(on) * v)[0] - quad)
    r.show("J", S.momentum.J)
    r.show("k", S.momentum.own)
    r.detail = ("two points and a rotor: K about C = J omega + k with the shares' sums; J the "
                "locked inertia about C (positive definite)")


# ---- X1.3: E1.4-E1.9 --------------------------------------------------------------------
@check("X1.3")
def x2_2(r: Report) -> None:
    S = mm.moments_system()
    am = momentum.angular_momentum()
    J1, own1 = _one_point(S.momentum.J), _one_point(S.momentum.own)
    assert_same("X1.3 J at one point = E1.5 (derived)", J1, _paper(am.J))
    assert_same("X1.3 J at one point = E1.5 (printed)", J1, P.E1_5.xreplace({nt.mu: P.MU}))
    assert_same("X1.3 k at one point = mu OP x V_r (E1.4)", own1, _paper(am.own))
    assert_same("X1.3 K at one point = E1.6 (printed)", _one_point(S.momentum.K),
                P.E1_6.xreplace({nt.mu: P.MU}))
    # E1.7: the theorem applied to the moments' K, then one point
    residual = _one_point(momentum.flight_dynamics(S).residual)
    assert_same("X1.3 E1.7 at one point (derived)", residual,
                _paper(momentum.flight_dynamics().residual))
    assert_same("X1.3 E1.7 at one point (printed)", residual, P.E1_7.xreplace({nt.mu: P.MU}))
    # the code's Euler form of the moments is the one point's (derive.momentum)
    form = mm.flight_form()
    point = momentum.flight_dynamics_euler()
    assert_same("X1.3 Euler's forcing at one point", _one_point(form.inline(form.forcing)),
                _paper(point.inline(point.forcing)))
    # E1.9: |K|^2 is the moments' at one point
    assert_same("X1.3 E1.9 at one point", _one_point(momentum.integral_of_kinetic_moment(S)),
                P.E1_9.xreplace({nt.mu: P.MU}))
    r.detail = "one point's moments: J = E1.5, k = mu OP x V_r, K = E1.6, E1.7, E1.9"


# ---- X1.4: E1.10-E1.16 --------------------------------------------------------------------
@check("X1.4")
def x2_3(r: Report) -> None:
    S = mm.moments_system()
    CS, d = impact.lever(S)
    CS1, d1 = impact.lever()
    assert_same("X1.4 CS at one point", _one_point(CS), _paper(CS1))
    assert_same("X1.4 d at one point = E1.10 (printed)", _one_point(d), P.E1_10_D)
    im, im1 = impact.impact_map(S), impact.impact_map()
    assert_same("X1.4 jump of V_C = E1.11", im.velocity_jump, P.E1_11_JUMP)
    assert_same("X1.4 omega+ at one point (E1.12)", _one_point(im.omega_plus), im1.omega_plus)
    J, d_ = im.omega_jump_system
    assert_same("X1.4 J (omega+ - omega-) = I d at one point", _one_point(J),
                P.E1_5.xreplace({nt.mu: P.MU}))
    assert_same("X1.4 v_n at one point = E1.14 (printed)", _one_point(im.normal_velocity),
                P.E1_14)
    assert_same("X1.4 k at one point = E1.16 (printed)", _one_point(im.k), P.E1_16,
                given=W_IS_JINV_D)
    assert_same("X1.4 I = E1.15 (Newton's law, k of the system)", im.impulse, im1.impulse)
    assert_same("X1.4 height of S at one point", _one_point(impact.height(S)),
                _paper(impact.height()))
    r.detail = "one point's moments: d = E1.10, E1.11, E1.12, v_n = E1.14, E1.15, k = E1.16"


# ---- X1.5: persistent contact and the rough plane ----------------------------------------
@check("X1.5")
def x2_4(r: Report) -> None:
    S = mm.moments_system()
    cd, cd1 = contact.contact_dynamics(S), contact.contact_dynamics()
    assert_same("X1.5 contact: dv_n/dt at N = 0", _one_point(cd.a_free), _paper(cd1.a_free))
    f, d = cd.omega_rhs
    f1, d1 = cd1.omega_rhs
    assert_same("X1.5 contact: forcing of omega'", _one_point(f), _paper(f1))
    dl, dl1 = fr.delassus(S), fr.delassus()
    assert_same("X1.5 rough: Delassus W", _one_point(dl.matrix), _paper(dl1.matrix))
    assert_same("X1.5 rough: the solves' right-hand sides CS x a_k",
                sp.Matrix([list(_one_point(v)) for v in dl.rhs]),
                sp.Matrix([list(_paper(v)) for v in dl1.rhs]))
    sc, sc1 = fr.sliding_contact(S), fr.sliding_contact()
    assert_same("X1.5 sliding: dv_n/dt at N = 0", _one_point(sc.a_free), _paper(sc1.a_free))
    assert_same("X1.5 sliding: lever", _one_point(sc.lever), _paper(sc1.lever))
    st, st1 = fr.sticking_contact(S), fr.sticking_contact()
    assert_numeric("X1.5 sticking: dv_S/dt at R = 0", _one_point(st.a_free),
                   _paper(st1.a_free))
    cw, cw1 = fr.contact_wrench(S), fr.contact_wrench()
    assert_numeric("X1.5 wrench: G", _one_point(cw.matrix), _paper(cw1.matrix))
    assert_numeric("X1.5 wrench: du/dt at no reaction", _one_point(cw.a_free),
                   _paper(cw1.a_free))
    r.detail = ("one point's moments: contact's a_free and forcing; rough plane's W, sliding, "
                "sticking and the wrench's G and a_free")

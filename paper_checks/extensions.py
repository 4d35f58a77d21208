"""Checks of the extensions beyond the paper (``EXTENSIONS.md``, IDs ``X...``).

X1.1: the rough plane of :mod:`derive.friction` with ``mu_f = 0`` is the paper's smooth
plane: the frictional impact gives back E1.11, E1.12, E1.15 and E1.16 under each
restitution model, and sliding contact gives the smooth contact of
:mod:`derive.contact`.  The derivations are read through their module (``fr.delassus()``
...) so that a test can break one and see the check fail.
"""
from __future__ import annotations

import sympy as sp

from derive import friction as fr
from derive import notation as nt
from derive.contact import A_FREE, contact_dynamics
from derive.impact import K_SYMBOL, V_N_MINUS, impact_map, lever

from .exact import assert_numeric, assert_same
from .registry import CheckFailed, Report, check


def _impulse_of_each_model(rate_n: sp.Expr) -> dict:
    """Integrate the normal velocity ``dv_Z/dp = rate_n`` (a constant) from ``v_n-`` and
    end the impact by each restitution model's termination: the normal impulse."""
    p, s = sp.symbols("p s", nonnegative=True)
    v_n = V_N_MINUS + sp.integrate(rate_n, (s, 0, p))
    E_n = sp.integrate(v_n.xreplace({p: s}), (s, 0, p))
    (p_c,) = sp.solve(sp.Eq(v_n, 0), p)
    E_c = E_n.xreplace({p: p_c})
    dk = fr.darboux_keller()
    out = {}
    for model, term in dk.terminations.items():
        expr = term.xreplace({fr.E_N: E_n, fr.P_N: p, fr.V_S[2]: v_n, fr.E_C: E_c,
                              fr.P_C: p_c, fr.V_N0: V_N_MINUS})
        roots = sp.solve(expr, p)
        # restitution ends after compression: the root p_c (1 + e), not p_c (1 - e)
        after = [r for r in roots if sp.expand(sp.cancel((r - p_c) / p_c) - nt.e) == 0]
        if len(after) != 1:
            raise CheckFailed(f"X1.1 ({model}): the end of restitution is none of {roots}")
        out[model] = after[0]
    return out


@check("X1.1")
def x1_1(r: Report) -> None:
    im = impact_map()
    _, d = lever()
    zero = {fr.mu_f: 0}
    dl = fr.delassus()
    dk = fr.darboux_keller()
    # the normal column's solve is E1.12's: CS x a_3 = d, so Y_3 = w (J w = d)
    assert_same("X1.1 J Y_3 = CS x n = d", dl.rhs[2], d)
    as_w = dict(zip(fr.Y[2], nt.W))
    assert_same("X1.1 W_ZZ = k (E1.16)", dl.matrix[2, 2].xreplace(as_w), im.k)
    # Darboux-Keller at mu_f = 0: dP/dp = e_Z, dv/dp = W e_Z whatever the slip
    assert_same("X1.1 dP/dp at mu_f = 0", dk.slip_impulse_rate.xreplace(zero),
                sp.Matrix([0, 0, 1]))
    rate = dk.slip_rate.xreplace(zero)
    if rate.free_symbols & set(fr.SIGMA):
        raise CheckFailed("X1.1: at mu_f = 0 the impact still depends on the slip direction")
    # each restitution model ends at E1.15's impulse (k kept as the symbol of E1.16)
    impulses = _impulse_of_each_model(rate[2].xreplace({fr.W_ZZ: K_SYMBOL}))
    for model, impulse in impulses.items():
        assert_same(f"X1.1 impulse, {model} (E1.15)", impulse, im.impulse)
    # the state after the total impulse P = (0, 0, I): E1.11 and E1.12
    P = dict(zip(fr.P_IMP, (0, 0, nt.I)))
    assert_same("X1.1 jump of V_C (E1.11)", dl.velocity_jump.xreplace(P), im.velocity_jump)
    assert_same("X1.1 omega+ (E1.12)", nt.omega + dl.omega_jump.xreplace(P).xreplace(as_w),
                im.omega_plus)
    # sliding contact at mu_f = 0 is derive/contact.py's smooth contact
    sc = fr.sliding_contact()
    cd = contact_dynamics()
    f_c, d_c = cd.omega_rhs
    assert_same("X1.1 sliding: forcing of omega'", sc.forcing, f_c)
    assert_same("X1.1 sliding: lever of N (J wf = d)", sc.lever.xreplace(zero), d_c)
    # so wf is contact's w and omega'_0 its free omega'
    rename = {**dict(zip(fr.W_SLIDE, nt.W)), **dict(zip(fr.OMEGA_DOT_0, nt.omega_dot))}
    assert_same("X1.1 sliding: dv_n/dt at N = 0", sc.a_free.xreplace(zero).xreplace(rename),
                cd.a_free)
    assert_same("X1.1 sliding: coefficient of N in dv_n/dt (E1.16's k)",
                sc.k_f.xreplace(zero).xreplace(rename), im.k)
    # N itself, a quotient of the two: at exact rational points (its symbolic difference,
    # when not zero, is slow to expand)
    N_contact = cd.normal_force.xreplace({A_FREE: cd.a_free, K_SYMBOL: im.k})
    assert_numeric("X1.1 sliding: N", sc.normal_force.xreplace(zero).xreplace(rename),
                   N_contact)
    assert_same("X1.1 sliding: V_C'", sc.acc_C.xreplace(zero),
                sp.Matrix([0, 0, cd.z_acceleration]))
    assert_same("X1.1 sliding: omega'", sc.omega_dot.xreplace(zero).xreplace(rename),
                nt.omega_dot + nt.N * nt.W)
    r.show("impulse (every restitution model, mu_f = 0)", impulses["energetic"])
    r.detail = ("mu_f = 0: W_ZZ = k; energetic, Poisson and Newton end at E1.15's I; jumps "
                "E1.11, E1.12; sliding N, V_C', omega' = derive/contact.py")

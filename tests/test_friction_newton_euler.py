"""The rough plane's derived functions against an independent Newton–Euler formulation.

The derivation (derive/friction.py, packaged by derive/friction_models.py and evaluated
here by derive/emit/numpy_backend.py, the reference the emitted C is compared with in
test_friction_emit.py) against tests/newton_euler_friction.py: Newton for the carrier
and for the point, Euler for the carrier about O, the reaction at S, solved as one
stacked linear system; the impulse form of the same laws for the inverse inertia at S.
Hundreds of random states (tests/cases.py), random friction coefficients and slip
directions.
"""
from __future__ import annotations

import numpy as np
import pytest

import newton_euler_friction as ne
from cases import cases, rel_err
from derive import darboux_keller as dk
from derive import friction_models as fm
from derive.emit.numpy_backend import numpy_function

N_STATES = 300
TOL = 1e-11


@pytest.fixture(scope="module")
def f():
    return {spec.name: numpy_function(spec.name) for spec in fm.friction_specs()}


def _states(n, seed):
    rng = np.random.default_rng(seed)
    for c in cases(n, seed=seed):
        yield c, rng


def test_delassus_is_the_inverse_inertia_at_S(f):
    worst = worst_v = worst_sym = 0.0
    for c, _ in _states(N_STATES, 41):
        w6, v_S = f["general_delassus"](c.q_general, c.u, c.s, c.p)
        W = dk.full(w6)
        W_ne = ne.inverse_inertia_at_S(c.q_general, c.u, c.s, c.p)
        worst = max(worst, rel_err(W, W_ne))
        worst_sym = max(worst_sym, rel_err(W_ne, W_ne.T))
        worst_v = max(worst_v, rel_err(v_S, ne.velocity_of_S(c.q_general, c.u, c.s, c.p)))
        assert np.linalg.eigvalsh(W)[0] > 0.0
        (v_only,) = f["general_contact_velocity"](c.q_general, c.u, c.s, c.p)
        assert rel_err(v_only, v_S) < 1e-14
    print(f"W {worst:.1e}, v_S {worst_v:.1e}, asymmetry of the NE matrix {worst_sym:.1e}")
    assert worst < TOL and worst_v < TOL and worst_sym < TOL


def test_delassus_closed_form_through_solves(f):
    """W = 1/(m+M) 1 + A [CS]x^T J^-1 [CS]x A^T (the issue's form, with J of E1.5 and
    CS = OS - m/(m+M) OP, evaluated with numpy.linalg.inv): the same numbers."""
    for c, _ in _states(100, 43):
        w6, _ = f["general_delassus"](c.q_general, c.u, c.s, c.p)
        mu_red = c.m * c.M / (c.m + c.M)
        r = c.r
        J = np.diag(c.J) + mu_red * (r @ r * np.eye(3) - np.outer(r, r))
        X = ne.skew(c.s - c.m / (c.m + c.M) * r)
        W = np.eye(3) / (c.m + c.M) + c.A @ X.T @ np.linalg.inv(J) @ X @ c.A.T
        assert rel_err(dk.full(w6), W) < TOL


def test_apply_impulse(f):
    for c, rng in _states(N_STATES, 47):
        P = rng.normal(size=3)
        (q_plus,) = f["general_apply_impulse"](c.q_general, c.u, c.s, c.p, P)
        want = ne.apply_impulse(c.q_general, c.u, c.s, c.p, P)
        assert rel_err(q_plus, want) < TOL
        # and the velocity of S moves by W P
        w6, v_S = f["general_delassus"](c.q_general, c.u, c.s, c.p)
        (after,) = f["general_contact_velocity"](q_plus, c.u, c.s, c.p)
        assert rel_err(after - v_S, dk.full(w6) @ P) < 1e-10


def test_impulse_rates_slip_and_stick(f):
    n_stick = 0
    for c, rng in _states(N_STATES, 53):
        mu = rng.uniform(0.0, 1.5)
        w6, v_S = f["general_delassus"](c.q_general, c.u, c.s, c.p)
        W_ne = ne.inverse_inertia_at_S(c.q_general, c.u, c.s, c.p)
        y = np.array([*v_S, *rng.normal(size=2), *rng.normal(size=2)])
        (dy,) = f["impulse_slip_rate"](y, w6, [mu])
        want = ne.slip_rate(W_ne, v_S, mu)
        assert rel_err(dy[:3], want) < TOL
        sig = v_S[:2] / np.linalg.norm(v_S[:2])
        assert rel_err(dy[3:5], -mu * sig) < 1e-14
        assert dy[5] == y[2] and dy[6] == pytest.approx(-mu * np.linalg.norm(v_S[:2]), rel=1e-14)
        # the same rate along the unit direction (the runtime's polar slip stage)
        (dv,) = f["impulse_slip_direction_rate"](sig, w6, [mu])
        assert rel_err(dv, want) < TOL
        # stick
        y[0:2] = 0.0
        dy, tau, margin = f["impulse_stick_rate"](y, w6, [mu])
        tau_ne, dvn_ne = ne.stick_rate(W_ne)
        assert rel_err(tau, tau_ne) < TOL
        assert dy[2] == pytest.approx(dvn_ne, rel=TOL)
        assert np.all(np.abs(dy[:2]) == 0.0) and rel_err(dy[3:5], tau_ne) < TOL
        # with tau the tangential velocity does not move, and dv_n/dp > 0 (no jam)
        assert np.abs((W_ne @ np.array([*tau, 1.0]))[:2]).max() < 1e-12 * np.abs(W_ne).max()
        assert dy[2] > 0.0
        assert (margin[0] >= 0.0) == (np.linalg.norm(tau_ne) <= mu)
        n_stick += margin[0] >= 0.0
    assert 0.1 * N_STATES < n_stick < 0.9 * N_STATES      # both kinds were exercised


def test_resliding_ray(f):
    """Where stick is impossible the derived ray (Newton on |sigma(c)|^2 = 1) is the one
    and only ray found by scanning the circle."""
    seen = 0
    for c, rng in _states(100, 59):
        w6, _ = f["general_delassus"](c.q_general, c.u, c.s, c.p)
        W = dk.full(w6)
        tau, _ = ne.stick_rate(ne.inverse_inertia_at_S(c.q_general, c.u, c.s, c.p))
        mu = rng.uniform(0.05, 0.95) * np.linalg.norm(tau)       # stick impossible
        rays = ne.resliding_rays(W, mu)
        assert len(rays) == 1, rays
        c_ray, sigma = dk.resliding_ray(W, mu)
        assert c_ray == pytest.approx(rays[0][0], rel=1e-9)
        assert np.abs(sigma - rays[0][1]).max() < 1e-9
        assert np.linalg.norm(sigma) == pytest.approx(1.0, abs=1e-14)
        # and with stick possible there is none
        assert ne.resliding_rays(W, 1.05 * np.linalg.norm(tau)) == []
        seen += 1
    assert seen == 100


def _contact_inputs(c, rng):
    sdot = rng.normal(size=3)
    mu = rng.uniform(0.0, 1.2)
    th = rng.uniform(-np.pi, np.pi)
    return sdot, mu, np.array([np.cos(th), np.sin(th)])


def test_sliding_contact(f):
    worst = {"dq": 0.0, "N": 0.0, "a_t": 0.0}
    for c, rng in _states(N_STATES, 61):
        sdot, mu, sigma = _contact_inputs(c, rng)
        dq, N, v_t, a_t = f["general_sliding_rhs"](c.q_general, c.u, c.s, sdot, c.p, [mu],
                                                  sigma)
        dq_ne, N_ne, a_S = ne.sliding(c.q_general, c.u, c.s, sdot, c.p, mu, sigma)
        scale = (c.M + c.m) * c.g
        worst["dq"] = max(worst["dq"], rel_err(dq, dq_ne))
        worst["N"] = max(worst["N"], abs(N[0] - N_ne) / max(abs(N_ne), scale))
        worst["a_t"] = max(worst["a_t"], np.abs(a_t - a_S[:2]).max()
                           / max(np.abs(a_S).max(), c.g))
        assert abs(a_S[2]) < 1e-10 * max(np.abs(a_S).max(), c.g)     # S stays on the plane
        assert rel_err(v_t, ne.velocity_of_S(c.q_general, c.u, c.s, c.p)[:2]) < TOL
    print({k: f"{v:.1e}" for k, v in worst.items()})
    assert max(worst.values()) < TOL


def test_sticking_contact(f):
    worst = {"dq": 0.0, "R": 0.0}
    for c, rng in _states(N_STATES, 67):
        sdot, _, _ = _contact_inputs(c, rng)
        dq, R = f["general_sticking_rhs"](c.q_general, c.u, c.s, sdot, c.p)
        dq_ne, R_ne, a_S = ne.sticking(c.q_general, c.u, c.s, sdot, c.p)
        worst["dq"] = max(worst["dq"], rel_err(dq, dq_ne))
        worst["R"] = max(worst["R"], np.abs(R - R_ne).max()
                         / max(np.abs(R_ne).max(), (c.M + c.m) * c.g))
        assert np.abs(a_S).max() < 1e-10 * max(np.abs(dq_ne).max(), c.g)
    print({k: f"{v:.1e}" for k, v in worst.items()})
    assert max(worst.values()) < TOL


def test_sticking_reaction_is_the_sliding_one_on_the_cone(f):
    """On the cone's edge the two phases agree: with mu = |R_t|/R_Z and the slip direction
    -R_t/|R_t| the sliding reaction is the sticking one and S does not accelerate."""
    for c, rng in _states(100, 71):
        sdot, _, _ = _contact_inputs(c, rng)
        dq, R = f["general_sticking_rhs"](c.q_general, c.u, c.s, sdot, c.p)
        if R[2] <= 0.0:
            continue
        mu = np.hypot(R[0], R[1]) / R[2]
        sigma = -R[:2] / np.hypot(R[0], R[1])
        dq_s, N, _, a_t = f["general_sliding_rhs"](c.q_general, c.u, c.s, sdot, c.p, [mu],
                                                  sigma)
        assert N[0] == pytest.approx(R[2], rel=1e-10)
        assert rel_err(dq_s, dq) < 1e-10
        assert np.abs(a_t).max() < 1e-9 * max(np.abs(dq).max(), c.g)


def test_friction_does_no_positive_work_in_sliding(f):
    """The reaction's power in sliding, R . v_S with R = (m+M)(V_C' + g e_Z) read from the
    derived accelerations, is -mu N |v_t| <= 0 when dir = v_t/|v_t| and N >= 0."""
    for c, rng in _states(N_STATES, 73):
        sdot, mu, _ = _contact_inputs(c, rng)
        q = c.q_general.copy()
        v_S = ne.velocity_of_S(q, c.u, c.s, c.p)
        q[5] -= v_S[2]                              # v_n = 0: S slides on the plane
        v_t = ne.velocity_of_S(q, c.u, c.s, c.p)[:2]
        sigma = v_t / np.linalg.norm(v_t)
        dq, N, _, _ = f["general_sliding_rhs"](q, c.u, c.s, sdot, c.p, [mu], sigma)
        R = (c.M + c.m) * (dq[3:6] + np.array([0.0, 0.0, c.g]))
        power = R @ ne.velocity_of_S(q, c.u, c.s, c.p)
        assert power == pytest.approx(-mu * N[0] * np.linalg.norm(v_t),
                                      abs=1e-12 * (c.M + c.m) * c.g * np.linalg.norm(v_t))
        if N[0] >= 0.0:
            assert power <= 1e-12 * (c.M + c.m) * c.g * np.linalg.norm(v_t)

"""The rough plane against closed forms: a sphere whose point sits at its centre.

Radius R, carrier inertia J (isotropic), point at the centre (so C is the centre and
S = C - R e_Z).  Then W = diag(k_t, k_t, 1/(m+M)) in fixed axes with
k_t = 1/(m+M) + R^2/J: the normal impulse does not couple to the slip.

* Impact, falling at v_z < 0 with slip v_t0: the normal impulse is
  P_n = (1 + e)(m+M)|v_z| under every restitution model (the normal velocity is linear
  in p); the slip changes by -mu P_n k_t along v_t0 while it lasts, so
  v_t+ = v_t0 (1 - mu P_n k_t/|v_t0|) if that is positive, else S sticks (v_t+ = 0,
  P_t = -v_t0/k_t).
* Sliding on the plane: N = (m+M) g and the slip decays at
  mu N k_t = mu g (1 + (m+M) R^2/J) along a fixed direction until it vanishes at
  t* = |v_t|/(mu g (1 + (m+M) R^2/J)); C decelerates at mu g until then, and rolls at
  constant velocity after: the sticking phase holds with R = (0, 0, (m+M) g).
* A homogeneous ball (J = 2/5 (m+M) R^2) thrown without spin: rolls at 5/7 of its speed.

The derived functions are integrated with SciPy (DOP853) to the stick event.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from cases import rotation_from_quaternion
from derive import darboux_keller as dk
from derive.emit.numpy_backend import numpy_function

U0 = np.zeros(9)      # the point at rest at the centre


def sphere_state(rng, M, m, J, R, V_C, omega_fixed):
    A = rotation_from_quaternion(rng.normal(size=4))
    q = np.concatenate([[0.3, -0.2, R], V_C, A.T @ omega_fixed, A.ravel()])
    return q, np.array([M, m, J, J, J, 9.81])


def lowest(q, R):
    A = q[9:18].reshape(3, 3)
    n, w = A[2], q[6:9]
    return -R * n, -R * np.cross(n, w)          # s and its rate: n' = n x omega


def slip_of(q, R, params):
    s, _ = lowest(q, R)
    (v,) = numpy_function("general_contact_velocity")(q, U0, s, params)
    return v


@pytest.mark.parametrize("restitution", ["energetic", "poisson", "newton"])
def test_impact_of_a_spinning_sphere(restitution):
    rng = np.random.default_rng(3)
    kinds = set()
    for _ in range(60):
        M, m, R = rng.uniform(0.5, 3), rng.uniform(0.05, 1), rng.uniform(0.1, 0.6)
        J = rng.uniform(0.2, 0.7) * (M + m) * R * R
        mu, e = rng.uniform(0.05, 1.0), rng.uniform(0.0, 1.0)
        vz = rng.uniform(0.5, 4.0)
        q, params = sphere_state(rng, M, m, J, R, np.r_[rng.normal(size=2), -vz],
                                 rng.normal(0, 5, 3))
        s, _ = lowest(q, R)
        v0 = slip_of(q, R, params)
        assert v0[2] == pytest.approx(-vz, rel=1e-12)
        res = dk.impact(q, U0, s, params, mu, e, restitution)
        k_t = 1 / (M + m) + R * R / J
        P_n = (1 + e) * (M + m) * vz
        vt0 = v0[:2]
        reduce = mu * P_n * k_t
        if np.linalg.norm(vt0) > reduce:
            vt_plus = vt0 * (1 - reduce / np.linalg.norm(vt0))
            P_t = -mu * P_n * vt0 / np.linalg.norm(vt0)
            kinds.add("slip")
        else:
            vt_plus, P_t = np.zeros(2), -vt0 / k_t
            kinds.add("stick")
        scale = np.abs(v0).max()
        assert res.impulse[2] == pytest.approx(P_n, rel=1e-10)
        assert np.abs(res.impulse[:2] - P_t).max() < 1e-10 * P_n
        assert np.abs(res.v_plus - np.r_[vt_plus, e * vz]).max() < 1e-10 * scale
        # the state after, through the derived map: V_C and omega (fixed axes)
        V_plus = q[3:6] + res.impulse / (M + m)
        A = q[9:18].reshape(3, 3)
        w_plus = A @ q[6:9] - R / J * np.cross([0.0, 0.0, 1.0], res.impulse)
        assert np.abs(res.q_plus[3:6] - V_plus).max() < 1e-10 * scale
        assert np.abs(A @ res.q_plus[6:9] - w_plus).max() < 1e-10 * max(1.0, np.abs(w_plus).max())
        assert np.abs(slip_of(res.q_plus, R, params) - res.v_plus).max() < 1e-10 * scale
    assert kinds == {"slip", "stick"}


def _slide(q0, R, params, mu, t_max):
    """Integrate general_sliding_rhs from q0 (S on the plane, slipping) to the stop of
    the slip: (t*, q at t*, [N along the way])."""
    rhs = numpy_function("general_sliding_rhs")
    sigma0 = slip_of(q0, R, params)[:2]
    sigma0 /= np.linalg.norm(sigma0)
    normals = []

    def f(_t, q):
        s, sdot = lowest(q, R)
        vt = slip_of(q, R, params)[:2]
        dq, N, _, _ = rhs(q, U0, s, sdot, params, [mu], vt / np.linalg.norm(vt))
        normals.append(N[0])
        return dq

    def stop(_t, q):
        return slip_of(q, R, params)[:2] @ sigma0
    stop.terminal, stop.direction = True, -1
    sol = solve_ivp(f, (0.0, t_max), q0, method="DOP853", rtol=1e-12, atol=1e-13,
                    events=[stop])
    assert sol.status == 1, sol.message
    return sol.t_events[0][0], sol.y_events[0][0], np.array(normals)


def test_landing_sliding_then_rolling():
    """e = 0: the sphere lands (closed-form impact), slides until the closed-form stick
    time, then rolls with the velocity it had there."""
    rng = np.random.default_rng(5)
    ran = 0
    for _ in range(3):
        M, m, R = rng.uniform(0.5, 3), rng.uniform(0.05, 1), rng.uniform(0.1, 0.6)
        J = rng.uniform(0.2, 0.7) * (M + m) * R * R
        mu, g = rng.uniform(0.1, 0.6), 9.81
        q, params = sphere_state(rng, M, m, J, R, np.r_[3.0 * rng.normal(size=2), -1.0],
                                 rng.normal(0, 4, 3))
        s, _ = lowest(q, R)
        k_t = 1 / (M + m) + R * R / J
        vt0 = slip_of(q, R, params)[:2]
        if np.linalg.norm(vt0) <= mu * (M + m) * k_t * 1.2:
            continue                                       # it would stick at once
        res = dk.impact(q, U0, s, params, mu, 0.0)
        q1 = res.q_plus
        v1 = slip_of(q1, R, params)
        assert abs(v1[2]) < 1e-12
        rate = mu * g * (1 + (M + m) * R * R / J)
        t_star = np.linalg.norm(v1[:2]) / rate
        t, q2, normals = _slide(q1, R, params, mu, 3 * t_star)
        assert t == pytest.approx(t_star, rel=1e-9)
        assert np.abs(normals - (M + m) * g).max() < 1e-9 * (M + m) * g
        sigma = v1[:2] / np.linalg.norm(v1[:2])
        V_star = q1[3:5] - mu * g * t_star * sigma
        assert np.abs(q2[3:5] - V_star).max() < 1e-9 * np.abs(q1[3:6]).max()
        assert np.abs(slip_of(q2, R, params)).max() < 1e-9 * np.abs(v1).max()
        # rolling: the sticking phase keeps V_C, S at rest, R vertical
        stick = numpy_function("general_sticking_rhs")

        def f(_t, qq):
            s_, sdot_ = lowest(qq, R)
            return stick(qq, U0, s_, sdot_, params)[0]
        sol = solve_ivp(f, (0.0, 1.0), q2, method="DOP853", rtol=1e-12, atol=1e-13)
        q3 = sol.y[:, -1]
        s3, sd3 = lowest(q3, R)
        _, Rr = stick(q3, U0, s3, sd3, params)
        assert np.abs(q3[3:6] - q2[3:6]).max() < 1e-9 * np.abs(q2[3:6]).max()
        assert np.abs(Rr - [0.0, 0.0, (M + m) * g]).max() < 1e-9 * (M + m) * g
        assert np.abs(slip_of(q3, R, params)).max() < 1e-8 * np.abs(v1).max()
        ran += 1
    assert ran >= 2


def test_a_homogeneous_ball_rolls_at_five_sevenths():
    rng = np.random.default_rng(7)
    M, m, R, mu, v0 = 1.0, 0.3, 0.11, 0.25, 2.0
    J = 0.4 * (M + m) * R * R
    q, params = sphere_state(rng, M, m, J, R, np.array([v0, 0.0, 0.0]), np.zeros(3))
    t, q2, _ = _slide(q, R, params, mu, 10.0)
    assert q2[3] == pytest.approx(5 / 7 * v0, rel=1e-10)
    assert abs(q2[4]) < 1e-12
    assert t == pytest.approx(2 * v0 / (7 * mu * 9.81), rel=1e-10)

"""Box and cylinder in flight: their corner and rim impacts are single-point impacts at S,
exact as for the smooth shapes.  Checked against computations made apart from derive:

* the first impact of a spinning box whose lowest corner changes in flight (S jumps from
  one corner to another before it lands) and of a spinning cylinder landing on its rim:
  the torque-free rigid body (the point held fixed) integrated by SciPy, the lowest
  corner the least of the eight (the rim's lowest point by a bounded search over its
  angle), the time where it reaches the plane by brentq, and the impulse, omega+ and
  V_C+ of a rigid body struck there (Newton's e, a smooth plane);
* every impact of a box bouncing on a smooth plane: the energy lost is (1 - e) I |v_n-|/2,
  the horizontal momentum is kept, and K about C in fixed axes jumps by CS x (0, 0, I);
* a box corner striking a rough plane (Poisson's restitution) whose friction stops the
  slip early in the compression: v_S = v_S- + W P is linear in the impulse whatever its
  path (W the Delassus matrix of the corner), so compression ends at P_c = -W^-1 v_S-;
  restitution goes on sticking, along W^-1 e_z, until the normal impulse is (1 + e)
  times the compression's.
"""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

import derive
from derive import abi, layout

M, m, g = 1.0, 0.25, 9.81
J = np.array([0.05, 0.06, 0.02])
R_P = np.array([0.08, 0.0, 0.05])             # the point, fixed in the body
NU, MT = m / (M + m), M + m
OC = NU * R_P                                 # O -> C, body axes
I_C = np.diag(J) + M * (OC @ OC * np.eye(3) - np.outer(OC, OC)) \
    + m * ((R_P - OC) @ (R_P - OC) * np.eye(3) - np.outer(R_P - OC, R_P - OC))
BOX = (0.2, 0.1, 0.05)
CYL = (0.1, 0.15)                             # R, L
CORNERS = np.array([[sx * BOX[0], sy * BOX[1], sz * BOX[2]]
                    for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])


def _tilt(th, ph):
    Rx = np.array([[1, 0, 0], [0, math.cos(th), -math.sin(th)], [0, math.sin(th), math.cos(th)]])
    Ry = np.array([[math.cos(ph), 0, math.sin(ph)], [0, 1, 0], [-math.sin(ph), 0, math.cos(ph)]])
    return Rx @ Ry


def _scene(shape, A0, omega, e=0.8, duration=1.0, friction=0.0, Z=1.0):
    size = {"half_extents": list(BOX)} if shape == "box" else \
        {"radius": CYL[0], "half_length": CYL[1]}
    plane = {"restitution": e, **({"friction": friction} if friction else {})}
    return {"body": {"mass": M, "inertia": J.tolist(), "shape": shape, **size},
            "point": {"mass": m, "law": [repr(float(x)) for x in R_P]}, "plane": plane,
            "initial": {"com": [0.0, 0.0, Z], "matrix": A0.tolist(), "omega": list(omega)},
            "run": {"duration": duration, "rtol": 1e-12, "atol": 1e-14}}


def _lowest(shape, A):
    """The lowest point of the surface (body axes, from O) for the attitude A, found
    without derive.shapes: the least of the corners, or of the two rims over their angle."""
    n = A[2]
    if shape == "box":
        return CORNERS[np.argmin(CORNERS @ n)]
    best = None
    for z in (-CYL[1], CYL[1]):
        res = minimize_scalar(lambda p: n @ [CYL[0] * math.cos(p), CYL[0] * math.sin(p), z],
                              bounds=(-math.pi, math.pi), method="bounded",
                              options={"xatol": 1e-12})
        guess = res.x
        # polish: the rim's lowest point is along -(n_x, n_y) (stationary in the angle)
        for _ in range(3):
            d1 = n @ [-CYL[0] * math.sin(guess), CYL[0] * math.cos(guess), 0.0]
            d2 = n @ [-CYL[0] * math.cos(guess), -CYL[0] * math.sin(guess), 0.0]
            guess -= d1 / d2
        p = np.array([CYL[0] * math.cos(guess), CYL[0] * math.sin(guess), z])
        if best is None or n @ p < n @ best:
            best = p
    return best


def _free_flight(A0, omega0, Z0, t_end):
    """The torque-free rigid body (Euler's equations about C, A' = A skew(omega)) and C's
    parabola, by SciPy: ``pose(t) -> (A, omega, Z_C, Z_C')``."""
    def rhs(t, y):
        A, w = y[:9].reshape(3, 3), y[9:]
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        dw = np.linalg.solve(I_C, -np.cross(w, I_C @ w))
        return np.concatenate([(A @ W).ravel(), dw])
    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate([A0.ravel(), omega0]), method="DOP853",
                    rtol=1e-13, atol=1e-14, dense_output=True)

    def pose(t):
        y = sol.sol(t)
        return y[:9].reshape(3, 3), y[9:], Z0 - g * t * t / 2, -g * t
    return pose


def _struck(A, omega, V_C, S, e):
    """A rigid body struck at S (body axes from O) by a smooth plane (Newton's e):
    (impulse, omega+, V_C+), fixed axes for V_C."""
    CS = A @ (S - OC)
    I_w = A @ I_C @ A.T
    arm = np.cross(CS, [0.0, 0.0, 1.0])
    v_n = V_C[2] + (np.cross(A @ omega, CS))[2]
    impulse = -(1 + e) * v_n / (1 / MT + arm @ np.linalg.solve(I_w, arm))
    omega_plus = omega + A.T @ np.linalg.solve(I_w, arm * impulse)
    return impulse, omega_plus, V_C + np.array([0.0, 0.0, impulse / MT]), v_n


@pytest.mark.parametrize("shape, A0, omega0", [
    ("box", _tilt(0.5, 0.3), np.array([3.0, -2.0, 5.0])),
    ("cylinder", _tilt(1.1, 0.4), np.array([-4.0, 2.0, 6.0]))])
def test_a_spinning_body_lands_on_the_corner_or_rim_that_the_rigid_body_says(shape, A0,
                                                                             omega0):
    e = 0.8
    res = derive.simulate(_scene(shape, A0, omega0, e=e, duration=0.6))
    assert res.model == "general" and len(res.impacts) >= 1
    pose = _free_flight(A0, omega0, 1.0, 0.6)

    def height(t):
        A, _, Z, _ = pose(t)
        return Z + A[2] @ (_lowest(shape, A) - OC)
    t_hit = brentq(height, 0.05, 0.6, xtol=1e-14, rtol=1e-15)
    A, omega, _, Zd = pose(t_hit)
    S = _lowest(shape, A)
    if shape == "box":       # the corner that lands is not the one lowest at the start
        assert not np.array_equal(S, _lowest(shape, A0))
    impulse, omega_plus, V_plus, v_n = _struck(A, omega, np.array([0.0, 0.0, Zd]), S, e)
    t_imp, I, vm, vp = res.impacts[0]
    after = np.flatnonzero(res.row_kind == abi.index(abi.ROW_KINDS, "after_event"))[0]
    q = res.q[after]
    assert math.isclose(t_imp, t_hit, rel_tol=0, abs_tol=1e-10)
    assert math.isclose(I, impulse, rel_tol=1e-8)
    assert math.isclose(vm, v_n, rel_tol=1e-8) and math.isclose(vp, -e * v_n, rel_tol=1e-8)
    assert np.allclose(q[layout.GENERAL.omega], omega_plus, rtol=0, atol=1e-7)
    assert np.allclose(q[layout.GENERAL.com_velocity], V_plus, rtol=0, atol=1e-8)


def _energy_and_K(q):
    A = q[layout.GENERAL.A].reshape(3, 3)
    w, V = q[layout.GENERAL.omega], q[layout.GENERAL.com_velocity]
    return 0.5 * MT * V @ V + 0.5 * w @ I_C @ w, A @ I_C @ w, A


def test_a_bouncing_box_loses_what_each_impact_takes_and_keeps_its_momenta():
    e = 0.6
    res = derive.simulate(_scene("box", _tilt(0.4, -0.7), [2.0, 5.0, -3.0], e=e,
                                 duration=1.2, Z=0.6))
    after = np.flatnonzero(res.row_kind == abi.index(abi.ROW_KINDS, "after_event"))
    assert len(res.impacts) >= 4 and len(after) == len(res.impacts)
    E0, K0, _ = _energy_and_K(res.q[0])
    for k, row in enumerate(after):
        _, I, vm, _ = res.impacts[k]
        E_minus, K_minus, A = _energy_and_K(res.q[row - 1])
        E_plus, K_plus, _ = _energy_and_K(res.q[row])
        assert res.t[row - 1] == res.t[row]
        # potential energy unchanged across the impact; in flight T + potential is kept
        assert math.isclose(E_plus - E_minus, -(1 - e) * I * abs(vm) / 2, rel_tol=1e-9,
                            abs_tol=1e-12)
        S = CORNERS[np.argmin(CORNERS @ A[2])]
        CS = A @ (S - OC)
        assert np.allclose(K_plus - K_minus, np.cross(CS, [0.0, 0.0, I]), rtol=0, atol=1e-10)
        assert np.allclose(res.q[row, 3:5], res.q[0, 3:5], rtol=0, atol=1e-12)
        # in flight before this impact: K constant, T + potential constant
        E_prev, K_prev, _ = _energy_and_K(res.q[after[k - 1]] if k else res.q[0])
        Z = res.q[[after[k - 1] if k else 0, row - 1], 2]
        assert np.allclose(K_minus, K_prev, rtol=0, atol=1e-10)
        assert math.isclose(E_minus + MT * g * Z[1], E_prev + MT * g * Z[0], rel_tol=1e-10)
    del E0, K0


def test_a_box_corner_sticks_on_a_rough_plane_as_the_delassus_matrix_says():
    e, mu, A0, omega0 = 0.5, 5.0, _tilt(0.5, 0.3), np.array([1.0, -2.0, 0.5])
    doc = _scene("box", A0, omega0, e=e, duration=0.5, friction=mu)
    doc["plane"]["restitution_model"] = "poisson"
    res = derive.simulate(doc)
    assert res.model == "rough"
    pose = _free_flight(A0, omega0, 1.0, 0.5)
    t_hit = brentq(lambda t: pose(t)[2] + pose(t)[0][2] @ (_lowest("box", pose(t)[0]) - OC),
                   0.05, 0.5, xtol=1e-14)
    A, omega, _, Zd = pose(t_hit)
    CS = A @ (_lowest("box", A) - OC)
    I_w_inv = np.linalg.inv(A @ I_C @ A.T)
    skew = np.array([[0, -CS[2], CS[1]], [CS[2], 0, -CS[0]], [-CS[1], CS[0], 0]])
    W = np.eye(3) / MT + skew @ I_w_inv @ skew.T          # v_S = V_C + w x CS
    v_S = np.array([0.0, 0.0, Zd]) + np.cross(A @ omega, CS)
    P_c = -np.linalg.solve(W, v_S)
    along = np.linalg.solve(W, [0.0, 0.0, 1.0])           # sticking: v_t stays 0
    P = P_c + e * P_c[2] * along / along[2]
    # both inside the cone: the slip stops early, and restitution goes on sticking
    assert np.hypot(*P_c[:2]) < 0.5 * mu * P_c[2] and np.hypot(*along[:2]) < mu * along[2]
    after = np.flatnonzero(res.row_kind == abi.index(abi.ROW_KINDS, "after_event"))[0]
    q = res.q[after]
    assert math.isclose(res.t[after], t_hit, rel_tol=0, abs_tol=1e-10)
    V_plus = np.array([0.0, 0.0, Zd]) + P / MT
    assert np.allclose(q[layout.GENERAL.com_velocity], V_plus, rtol=0, atol=1e-8)
    omega_plus = omega + A.T @ (I_w_inv @ np.cross(CS, P))
    assert np.allclose(q[layout.GENERAL.omega], omega_plus, rtol=0, atol=1e-7)

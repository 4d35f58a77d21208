"""Issue 13: the runtime's Lie-group methods (crt_lie.h) against the classical DOP853 at
tight tolerance, and the invariants they keep by construction: K in fixed axes and |K|
(E1.1, E1.9) constant in each flight, A on SO(3), C on its parabola, the jumps of K and
C' at impacts (E1.10, E1.11)."""
from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from derive.runtime.driver import simulate
from derive.runtime.geometry import kinetic_moment, lowest_point_numeric
from derive.scene import parse_scene

from test_runtime import ball, scene_dict


def free(**run):
    doc = scene_dict(plane=None)
    doc["point"]["law"] = ["0.2*sin(3*t)", "0.1*cos(2*t)", "0.05*cos(5*t)"]
    doc["initial"]["omega"] = [0.5, -0.3, 1.0]
    doc["run"].update({"duration": 4.0, "model": "general", "outputs": ["pose"], **run})
    return doc


def run(doc, method, tol, **extra):
    d = copy.deepcopy(doc)
    d["run"].update(method=method, rtol=tol, atol=tol * 1e-2, **extra)
    res = simulate(d, progress=False)
    assert res.status == "done", res.status
    return res


def invariants(res):
    """Relative drift of |K| and of K in fixed axes over the rows, and max |A A^T - 1|,
    everything computed from the output rows (omega, A, the law)."""
    G = res.general
    A = G[:, 9:18].reshape(-1, 3, 3)
    K_body = kinetic_moment(res.scene, G[:, 6:9], res.scene.law.jets(res.t))
    K_fixed = np.einsum("nij,nj->ni", A, K_body)
    size = np.linalg.norm(K_fixed[0])
    return (np.max(np.abs(np.linalg.norm(K_body, axis=1) - size)) / size,
            np.max(np.linalg.norm(K_fixed - K_fixed[0], axis=1)) / size,
            np.max(np.abs(np.einsum("nij,nkj->nik", A, A) - np.eye(3))))


@pytest.mark.parametrize("method", ["lie", "lie5"])
@pytest.mark.parametrize("output_dt", [0.0, 0.05])
def test_lie_agrees_with_dop853_and_keeps_the_integrals(method, output_dt):
    ref = run(free(), "dop853", 1e-13, output_dt=output_dt if output_dt else 0.01)
    res = run(free(), method, 1e-12, output_dt=output_dt)
    # the same motion: compare on the reference's rows through its dense rows' times
    if output_dt:
        assert np.max(np.abs(res.general - ref.general)) < 2e-9
    else:
        assert abs(res.t[-1] - ref.t[-1]) < 1e-12
        assert np.max(np.abs(res.general[-1] - ref.general[-1])) < 2e-9
    k_norm, k_fixed, orth = invariants(res)
    assert k_norm < 1e-14 and k_fixed < 1e-14 and orth < 1e-14, (k_norm, k_fixed, orth)
    # C on its parabola exactly (E1.2 integrated)
    s = parse_scene(free())
    tau = res.t - s.t0
    np.testing.assert_allclose(res.general[:, 2], s.com[2] + s.com_velocity[2] * tau
                               - 0.5 * s.g * tau ** 2, rtol=1e-15, atol=1e-15)


def test_the_integrals_do_not_depend_on_the_tolerance():
    """At a loose tolerance the motion is less accurate, the integrals are not."""
    res = run(free(duration=40.0), "lie", 1e-4, output_dt=0.1)
    k_norm, k_fixed, orth = invariants(res)
    assert k_norm < 1e-14 and k_fixed < 1e-14 and orth < 1e-14, (k_norm, k_fixed, orth)


def bouncing(**run_):
    doc = scene_dict(run={"duration": 3.0, "outputs": ["pose", "impacts"], "model": "general",
                          **run_})
    doc["initial"]["omega"] = [2.0, -1.0, 3.0]
    return doc


def test_lie_bouncing_agrees_with_dop853():
    ref = run(bouncing(), "dop853", 1e-13)
    res = run(bouncing(), "lie", 1e-12)
    assert len(res.impacts) == len(ref.impacts) >= 3
    assert np.max(np.abs(res.impacts[:, 0] - ref.impacts[:, 0])) < 1e-9
    assert np.max(np.abs(res.impacts[:, 1] - ref.impacts[:, 1])) < 1e-8
    assert np.max(np.abs(res.general[-1] - ref.general[-1])) < 1e-8


def test_K_and_the_velocity_of_C_jump_as_E1_10_and_E1_11_say():
    """Between impacts K in fixed axes is constant to rounding; at an impact it jumps by
    I A d, d = CS x n, and C' by I/(m+M) along the vertical."""
    res = run(bouncing(), "lie", 1e-10)
    s = res.scene
    G, t, kinds = res.general, res.t, res.row_kind
    A = G[:, 9:18].reshape(-1, 3, 3)
    K_fixed = np.einsum("nij,nj->ni", A, kinetic_moment(s, G[:, 6:9], s.law.jets(t)))
    scale = np.linalg.norm(K_fixed[0])
    impacts = iter(res.impacts)
    start = 0
    for i, kind in enumerate(kinds):
        if kind != 1:                                  # not "before an event"
            continue
        flight = slice(start, i + 1)
        assert np.max(np.abs(K_fixed[flight] - K_fixed[start])) < 1e-13 * scale
        t_ev, impulse = next(impacts)[:2]
        assert abs(t[i] - t_ev) < 1e-15 and kinds[i + 1] == 2
        n = A[i][2]
        r = s.law.jets(np.array([t_ev]))[[0, 3, 6], 0]
        CS = lowest_point_numeric(s, n) - s.nu * r
        d = np.cross(CS, n)
        np.testing.assert_allclose(K_fixed[i + 1] - K_fixed[i], impulse * A[i] @ d,
                                   atol=1e-13 * scale)
        np.testing.assert_allclose(G[i + 1, 3:6] - G[i, 3:6],
                                   [0.0, 0.0, impulse / (s.M + s.m)], atol=1e-13)
        start = i + 1


@pytest.mark.parametrize("model", ["vertical", "attitude"])
def test_reduced_models_with_lie_equal_general(model):
    doc = bouncing() if model == "vertical" else free()
    doc["run"]["model"] = model
    doc["run"]["outputs"] = ["omega", "impacts"] if model == "vertical" else ["omega"]
    ref = run(doc, "dop853", 1e-13)
    res = run(doc, "lie", 1e-12)
    assert np.max(np.abs(res.q[-1] - ref.q[-1])) < 1e-8
    if model == "vertical":
        assert np.max(np.abs(res.impacts[:, 0] - ref.impacts[:, 0])) < 1e-9
        n = res.q[:, 5:8]
        assert np.max(np.abs(np.linalg.norm(n, axis=1) - 1)) < 4e-15


def test_contact_falls_back_to_the_classical_method():
    """Impacts accumulate into resting contact and the body lifts off again: in contact the
    Lie method hands over to DOP853 and takes the flight up again after lift-off."""
    doc = ball(e=0.3, z0=0.7, law=("0.05*sin(7*t)", "0", "0.3*sin(20*t)"), duration=1.5,
               rtol=1e-11, atol=1e-13, model="general")
    doc["initial"]["omega"] = [0.0, 0.0, 0.5]
    ref = run(doc, "dop853", 1e-11)
    res = run(doc, "lie", 1e-11)
    kinds = [e["kind"] for e in res.events]
    assert kinds == [e["kind"] for e in ref.events]
    assert "contact" in kinds and "lift_off" in kinds
    assert np.max(np.abs(np.array([e["t"] for e in res.events])
                         - np.array([e["t"] for e in ref.events]))) < 1e-7


@pytest.mark.parametrize("band, coefficients", [(0.98, "lie8"), (1.02, "lie5")])
def test_lie_takes_the_coefficients_its_tolerance_names(band, coefficients):
    """``lie`` runs the coefficients of lie8 below rtol 1e-6 and those of lie5 from it
    (derive/abi.py's METHODS): at 0.98 and 1.02 of the switch its rows are the named
    method's, to the bit."""
    rtol = band * 1e-6
    got = run(free(), "lie", rtol)
    named = run(free(), coefficients, rtol)
    other = run(free(), "lie5" if coefficients == "lie8" else "lie8", rtol)
    assert np.array_equal(got.general, named.general)
    assert not np.array_equal(got.general, other.general)


def test_each_method_takes_the_steps_of_its_order():
    """At rtol 1e-10 a method of order 8 takes a fraction of the steps of one of order 5
    on the same flight (steps grow as rtol^(-1/p): (1e-10)^(1/5 - 1/8) = 0.18 of them, up
    to the methods' constants): DOP853 against DOPRI5, lie8 against lie5, each run as
    named (the classical and the Lie methods, and the Lie methods' two orders, told
    apart by the runtime's dispatch)."""
    steps = {m: run(free(), m, 1e-10).stats["steps"]
             for m in ("dopri5", "dop853", "lie5", "lie8")}
    assert steps["dop853"] < 0.5 * steps["dopri5"], steps
    assert steps["lie8"] < 0.5 * steps["lie5"], steps
    # the Lie methods are not the classical ones under another name
    assert steps["lie5"] != steps["dopri5"] and steps["lie8"] != steps["dop853"], steps


def test_a_fast_spin_is_stepped_a_bounded_turn_at_a_time():
    """A steady spin about a principal axis (the point at rest at O): A(t) = Rz(w t), a
    turn of w T in all.  The Lie methods keep each step below a turn of LIE_MAX_TURN rad
    at the step's rate (derive/docs/runtime.md), so that the exponential coordinates stay
    where their series are exact to rounding and no chart is refused: the turn between
    successive step rows, taken from their attitudes, is at most that, none is refused,
    and the rows are the closed form's."""
    from derive.emit.runtime_backend import LIE_MAX_TURN
    w, T = 20.0, 2.0
    doc = scene_dict(plane=None)
    doc["point"]["law"] = ["0", "0", "0"]
    doc["initial"]["omega"] = [0.0, 0.0, w]
    doc["run"].update({"duration": T, "model": "general", "outputs": ["pose"]})
    res = run(doc, "lie", 1e-10, output_dt=0.0)
    A = res.general[:, 9:18].reshape(-1, 3, 3)
    c, s = np.cos(w * res.t), np.sin(w * res.t)
    Rz = np.zeros_like(A)
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, -s, s, c, 1.0
    assert np.max(np.abs(A - Rz)) < 1e-8
    cos_turn = (np.einsum("nji,nji->n", A[:-1], A[1:]) - 1.0) / 2.0
    turns = np.arccos(np.clip(cos_turn, -1.0, 1.0))
    assert np.max(turns) <= LIE_MAX_TURN * (1 + 1e-9), np.max(turns)
    assert len(res.t) - 1 >= math.ceil(w * T / LIE_MAX_TURN)
    assert res.stats["rejected"] == 0


# each unit quaternion's largest component is a different one of Shepperd's four branches
HALF_TURNS = {"about x": [0.0, 1.0, 0.0, 0.0], "about y": [0.0, 0.0, 1.0, 0.0],
              "about z": [0.0, 0.0, 0.0, 1.0]}


@pytest.mark.parametrize("axis", list(HALF_TURNS))
def test_a_flight_from_a_half_turn_agrees_with_dop853(axis):
    """Started half a turn about x, y or z (A = diag(1, -1, -1) and its like: a trace of
    -1, one diagonal entry the largest, the others tied at -1), the Lie method reads the
    attitude's quaternion off A by the branch of that entry (any other's root is 0) and
    flies as DOP853 does at 1e-13; the vertical model started with n exactly e_x, e_y or
    e_z builds its frame from a helper axis away from n (y when |n_x| > 0.8, else x: the
    other would leave no frame) and flies as DOP853 does."""
    doc = free(duration=1.0)
    doc["initial"]["quaternion"] = HALF_TURNS[axis]
    ref = run(doc, "dop853", 1e-13)
    res = run(doc, "lie", 1e-12)
    assert np.max(np.abs(res.general[-1] - ref.general[-1])) < 1e-9
    np.testing.assert_array_equal(res.general[0, 9:18], ref.general[0, 9:18])
    # n exactly along a body axis, e_x or e_y (set in the state itself: the scene's
    # attitude passes through a quaternion whose round-off tilts n by 1e-16, which a
    # frame built off n itself still survives)
    from derive.runtime.driver import prepare
    from derive.runtime.session import Session
    n = {"about x": [1.0, 0.0, 0.0], "about y": [0.0, 1.0, 0.0], "about z": [0.0, 0.0, 1.0]}
    up = bouncing(duration=1.0, model="vertical", outputs=["omega", "impacts"])
    got = {}
    for method, tol in (("dop853", 1e-13), ("lie", 1e-12)):
        doc = copy.deepcopy(up)
        doc["run"].update(method=method, rtol=tol, atol=tol * 1e-2)
        prep = prepare(doc)
        q0 = np.array(prep.start.q0, dtype=float)
        q0[5:8] = n[axis]
        session = Session(prep.library)
        session.set_law(prep.scene.runtime_law)
        got[method] = session.run(prep.scene.t0, 1.0, q0, prep.options, prep.parameters)
        assert got[method].status == "done"
    # (the Lie method's first row has n through its quaternion, to round-off)
    assert list(got["dop853"].q[0, 5:8]) == n[axis]
    assert np.max(np.abs(got["lie"].q[-1] - got["dop853"].q[-1])) < 1e-8

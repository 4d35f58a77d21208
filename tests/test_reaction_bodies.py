"""The independent contact reaction (derive/verify/reaction.py) of a carrier with several
points and rotors, against things computed another way, and the rough plane's judge
catching a runtime that sticks outside the cone on such scenes.

* Random states (0-6 points, 0-3 rotors, any attitude and spin): sticking and sliding
  reactions against tests/newton_euler_moments.py, where each rotor is a body of its own
  under its own torque with an arbitrary transverse moment (the reaction must not depend
  on it), the plane's force one more set of columns of its laws.
* Random rough scenes of tests/test_multibody.py's generator: the reaction on every
  contact row whose mode is known is the runtime's own (``Session.rough_rows``, its C),
  with the rows' attitude made orthonormal for both (the runtime and the laws here read a
  drifted A differently, by the drift times the speeds).
* A sphere driven by one rotor alone (psi'' = c t about a horizontal axis): while it
  rolls, F = -M R I c t/(J + M R^2) and N = M g (the closed form, Euler about O and
  Newton), so it slips at t* = mu_f (J + M R^2) g/(R I c).
* A runtime whose cone is 5 % wider (or narrower) than the scene's, as the mutant of issue
  36 made it: the rotor's sphere and the README's two-mass capsule run with mu_f 1.05
  (or 1/1.05) times the scene's, and judged under the scene's mu_f, are refused ("cone")
  where the honest runs pass.
"""
from __future__ import annotations

import copy
import dataclasses
import math
from importlib import resources

import numpy as np
import pytest
import tomllib

import newton_euler_moments as ne
from cases import rotation_from_quaternion
from derive.runtime.driver import simulate
from derive.verify import reaction as rx
from derive.verify.generators import random_bodies_scene
from derive.verify.judges import judge_run

E = np.eye(3)


def _random_bodies(rng, n_points: int, n_rotors: int):
    """(rx.Bodies, rx.Jets of one row, ne.System without its state) of random bodies on
    an ellipsoid with its centre off O."""
    masses = rng.uniform(0.05, 0.6, n_points)
    axes = rng.normal(size=(n_rotors, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None] if n_rotors else 1.0
    inertias = rng.uniform(0.005, 0.05, n_rotors)
    b = rx.Bodies(M=1.3, masses=masses, J=np.array([0.11, 0.14, 0.17]), g=9.81,
                  shape="ellipsoid", size=(0.5, 0.4, 0.3),
                  center=np.array([0.03, -0.02, 0.05]), mu_f=0.7, mu_s=0.0, mu_r=0.0,
                  axes=axes, inertias=inertias)
    pts = np.concatenate([rng.normal(0, 0.1, (n_points, 3)), rng.normal(0, 1, (n_points, 3)),
                          rng.normal(0, 5, (n_points, 3))], axis=1)
    rot = rng.normal(0, [1.0, 20.0, 50.0], (n_rotors, 3))
    jets = rx.Jets(pts[None], rot[None])
    sys_ = ne.System(M=b.M, J=b.J, g=b.g,
                     points=[ne.Point(m=mj, r=p[0:3], v=p[3:6], a=p[6:9])
                             for mj, p in zip(masses, pts)],
                     rotors=[ne.Rotor(axis=a, I=i, It=rng.uniform(0.2, 3.0) * i, rate=r[1],
                                      acc=r[2]) for a, i, r in zip(axes, inertias, rot)])
    return b, jets, sys_


def _ne_reaction(sys_, q, s, sd, directions):
    """Newton–Euler with the plane's force sum_i f_i d_i at S (d_i fixed axes) and the
    constraints e_i . A a_S = 0 on the fixed axes the force has a free component along
    (all three for sticking, Z for sliding): the f_i."""
    w, A = q[6:9], q[9:18].reshape(3, 3)
    cols, rows, rhs = [], [], []
    K, _, b = ne._system(sys_, q)
    for d in directions:
        cols.append(ne._system(sys_, q, (s, A.T @ d))[1])
    for i in range(len(directions)):
        e = A.T @ (E[2] if len(directions) == 1 else E[i])
        row = np.zeros(len(b))
        row[0:3], row[3:6] = e, np.cross(s, e)
        rows.append(row)
        rhs.append(-e @ (np.cross(w, np.cross(w, s)) + np.cross(w, sd)))
    n, k = len(b), len(directions)
    full = np.zeros((n + k, n + k))
    full[:n, :n], full[:n, n:] = K, np.array(cols).T
    full[n:, :n] = np.array(rows)
    x = np.linalg.solve(full, np.r_[b, rhs])
    return x[n:]


@pytest.mark.parametrize("n_points, n_rotors", [(0, 0), (0, 3), (1, 1), (2, 2), (6, 3)])
def test_the_reaction_of_several_bodies_is_newton_eulers_with_rotors_as_bodies(n_points,
                                                                               n_rotors):
    rng = np.random.default_rng(100 + 10 * n_points + n_rotors)
    for _ in range(10):
        b, jets, sys_ = _random_bodies(rng, n_points, n_rotors)
        A = rotation_from_quaternion(rng.normal(size=4))
        w = rng.normal(0, 2, 3)
        q = np.concatenate([rng.normal(size=3), rng.normal(size=3), w, A.ravel()])
        k = rx.kinematics(b, q[None], jets)
        # the velocity of S from the bodies' definition of C (ne: V_O from V_C)
        assert np.allclose(k.v_S[0], A @ (sys_.velocity_of_O(q) + np.cross(w, k.s[0])),
                           rtol=1e-12, atol=1e-12)
        one = np.ones(1, dtype=bool)
        R_ne = _ne_reaction(sys_, q, k.s[0], k.sd[0], E)
        got = rx.solve(b, k, one)
        scale = 1.0 + np.abs(R_ne).max()
        assert np.abs(got.R[0] - R_ne).max() < 1e-10 * scale
        assert np.abs(got.a_S[0]).max() < 1e-9 * scale
        sigma = rng.normal(size=2)
        sigma /= np.linalg.norm(sigma)
        (N_ne,) = _ne_reaction(sys_, q, k.s[0], k.sd[0],
                               [np.array([-b.mu_f * sigma[0], -b.mu_f * sigma[1], 1.0])])
        assert rx.solve(b, k, ~one, sigma[None]).N[0] == pytest.approx(N_ne, rel=1e-10,
                                                                        abs=1e-10)


def test_the_reaction_on_random_rough_scenes_is_the_runtimes():
    """The scenes of tests/test_multibody.py's rough test (seed 12): every contact row's
    mode known to the judge (sticking, or sliding with a slip that says its direction)."""
    rng = np.random.default_rng(12)
    judged = 0
    for n_points, n_rotors in ((0, 0), (0, 3), (2, 1), (6, 2), (3, 3), (1, 1), (5, 0),
                               (4, 2), (2, 3), (0, 1), (6, 3), (3, 0)):
        doc = random_bodies_scene(rng, 2.0, rough=True, n_points=n_points, n_rotors=n_rotors)
        doc["run"]["duration"] = min(doc["run"]["duration"], 2.0)
        if doc["run"]["method"] == "rk4":
            doc["run"]["step"] = 1e-3
        res = simulate(doc)
        s = res.scene
        rr = rx.contact_reactions(res, 10.0 * math.sqrt(s.rtol))
        rows = rr.rows[rr.known]
        if not len(rows):
            continue
        Q = res.model_q[rows].copy()
        U, _, Vt = np.linalg.svd(Q[:, 9:18].reshape(-1, 3, 3))
        Q[:, 9:18] = (U @ Vt).reshape(-1, 9)
        mode = rr.modes.mode[rows]
        _, R, v = res.session.rough_rows(res.t[rows], Q, mode)
        b = rx.Bodies.of(s)
        k = rx.kinematics(b, Q, rx.law_rows(s, res.t[rows]))
        slip = np.hypot(k.v_S[:, 0], k.v_S[:, 1])
        ours = rx.solve(b, k, mode == rx.STICKING, k.v_S[:, :2] / slip[:, None])
        assert np.abs(v - k.v_S).max() < 1e-12 * (1.0 + np.abs(v).max())
        assert np.abs(R - ours.R).max() < 1e-9 * b.weight, (n_points, n_rotors)
        judged += len(rows) if (n_points, n_rotors) != (0, 0) else 0
    assert judged > 1000


# ---- a sphere driven by one rotor ------------------------------------------------------------
M, RADIUS, J, I_ROTOR, G = 1.0, 0.5, 0.1, 0.01, 9.81
C_RATE = 343.0         # psi'' = c t


def rotor_sphere(mu: float) -> dict:
    """A homogeneous sphere (J = 2/5 M R^2) at rest on the plane, its rotor about the body's
    y axis through O spun up by psi = c t^3/6."""
    return {"name": "rotor-slip",
            "body": {"mass": M, "inertia": [J, J, J], "shape": "sphere", "radius": RADIUS},
            "rotor": [{"axis": [0.0, 1.0, 0.0], "inertia": I_ROTOR,
                       "law": f"{C_RATE!r}*t**3/6"}],
            "plane": {"restitution": 0.0, "friction": mu},
            "initial": {"com": [0.0, 0.0, RADIUS], "com_velocity": [0.0, 0.0, 0.0],
                        "omega": [0.0, 0.0, 0.0]},
            "run": {"duration": 0.3, "method": "dop853", "rtol": 1e-10, "atol": 1e-12}}


def test_a_sphere_spun_by_its_rotor_slips_where_the_closed_form_says():
    """While S sticks, Euler about O (y) J w' + I c t = -R F and Newton F = M R w' give F =
    -M R I c t/(J + M R^2), N = M g: the independent reaction on every sticking row, and
    the slip at t* = mu_f (J + M R^2) g/(R I c) (0.2 s)."""
    mu = 0.1
    result = simulate(rotor_sphere(mu))
    assert result.model == "moments_rough" and result.status == "done"
    modes = rx.row_modes(result)
    rows = np.flatnonzero(modes.mode == rx.STICKING)
    b = rx.Bodies.of(result.scene)
    k = rx.kinematics(b, result.model_q[rows], rx.law_rows(result.scene, result.t[rows]))
    got = rx.solve(b, k, np.ones(len(rows), dtype=bool))
    t = result.t[rows]
    F = -M * RADIUS * I_ROTOR * C_RATE * t / (J + M * RADIUS ** 2)
    assert len(rows) >= 5
    assert np.abs(got.R - np.c_[F, 0.0 * t, M * G + 0.0 * t]).max() < 1e-12 * M * G
    slips = [e["t"] for e in result.events if e["kind"] == "slip"]
    t_star = mu * (J + M * RADIUS ** 2) * G / (RADIUS * I_ROTOR * C_RATE)
    assert slips and slips[0] == pytest.approx(t_star, abs=1e-9)
    assert judge_run(result, RADIUS) == ("ok", "")


def _capsule() -> dict:
    path = resources.files("derive.scene") / "examples" / "two-mass-capsule.toml"
    return tomllib.loads(path.read_text())


@pytest.mark.parametrize("which", ["rotor", "capsule"])
def test_the_judge_refuses_a_cone_five_percent_off_on_scenes_of_several_bodies(which):
    """The run of a cone 5 % wider sticks past the scene's cone (its stick rows outside
    it); that of a cone 5 % narrower slips where the scene's cone still held (a slip
    inside it): both judged "cone" under the scene's mu_f, against the independent
    reaction of the points' and the rotor's laws."""
    doc = rotor_sphere(0.1) if which == "rotor" else _capsule()
    size = RADIUS if which == "rotor" else 0.15
    mu = doc["plane"]["friction"]
    assert judge_run(simulate(doc), size) == ("ok", "")
    for factor, why in ((1.05, "|R_t| - mu_f N"), (1 / 1.05, "inside the cone")):
        off = copy.deepcopy(doc)
        off["plane"]["friction"] = factor * mu
        result = simulate(off)
        result.__dict__["scene"] = dataclasses.replace(result.scene, friction=mu)
        verdict, detail = judge_run(result, size)
        assert verdict == "cone" and why in detail, (factor, verdict, detail)

"""The rough plane's decisions at 1 % of their thresholds.

Each scene puts one decision of the runtime within 1 % of its bound, on either side, so
that a bound or a threshold off by a few percent anywhere changes an asserted outcome
(``derive verify mutants`` checks that it does):

* the slip of a sliding sphere stops where the sticking reaction needs 0.99 mu_f N (it
  sticks) or 1.01 mu_f N (it slides on: a reversal); the stuck one slips again where
  |R_t| reaches mu_f N;
* a spinning sphere's spin stops where the drilling couple needs 0.99 mu_s N (held) or
  1.01 mu_s N (it turns on); a rolling one's rolling where the rolling couple needs 0.99 or
  1.01 mu_r N;
* a sphere driven up and down by its point lifts off where N = (m+M) g + m z'' reaches 0
  (the drive 1 % above the weight), and stays with the drive 1 % below.

The reference is computed another way: the reaction by Newton–Euler for the two bodies
(derive/verify/reaction.py, apart from the runtime), itself checked here against the
tests' own formulation (tests/newton_euler_friction.py) and the closed form of N.  The
friction coefficients of the scenes were found by a fixed-point iteration (mu = the
ratio at the decision / 0.99 or 1.01; the ratio hardly depends on mu); each test asserts
that its decision still falls in its 1 % band, so a scene that drifts off the boundary
fails rather than passes.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

import newton_euler_friction as ne
from cases import rotation_from_quaternion
from derive.runtime.driver import simulate
from derive.scene.law import compile_law
from derive.verify import reaction as rx
from derive.verify.judges import judge_run

G = 9.81
M, m, RADIUS, J = 1.0, 0.5, 0.5, 0.1
# the coefficients that put each decision at 0.99 and 1.01 of its bound
MU_STICK, MU_REVERSE = 0.00842567832099356, 0.008279626483585467
MU_S_HOLD, MU_S_TURN = 0.0025360801423543666, 0.0024854219767343937
MU_R_HOLD, MU_R_TURN = 0.03355218019572367, 0.03287210703003077


def sphere(law, mu=1.0, v0=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0), mu_s=0.0, mu_r=0.0,
           duration=0.3) -> dict:
    """A homogeneous sphere (J = 2/5 M R^2) resting on the plane at t = 0, its centre O
    moving at v0 and turning at omega, the point at r(t) (body axes)."""
    r = compile_law(tuple(law)).point(0.0)
    nu = m / (M + m)
    return {"name": "boundary",
            "body": {"mass": M, "inertia": [J, J, J], "shape": "sphere", "radius": RADIUS},
            "point": {"mass": m, "law": list(law)},
            "plane": {"restitution": 0.0, "friction": mu, "spin_friction": mu_s,
                      "rolling_resistance": mu_r},
            "initial": {"com": [nu * r[0], nu * r[1], RADIUS + nu * r[2]],
                        "com_velocity": [v0[0] + nu * r[3], v0[1] + nu * r[4],
                                         v0[2] + nu * r[5]],
                        "omega": list(omega)},
            "run": {"duration": duration, "method": "dop853", "rtol": 1e-10, "atol": 1e-12}}


def held_reaction(result, j: int) -> rx.Reaction:
    """The reaction at row j with S stuck and every couple held, apart from the runtime."""
    b = rx.Bodies.of(result.scene)
    k = rx.kinematics(b, result.model_q[[j]], rx.law_rows(result.scene, result.t[[j]]))
    one = np.ones(1, dtype=bool)
    return rx.solve(b, k, one, None, one if b.mu_s > 0 else None,
                    one if b.mu_r > 0 else None)


def decisions(result, kinds) -> list:
    """(kind, row after it) of the events of these kinds, in order."""
    modes = rx.row_modes(result)
    return [(modes.event[j], j) for j in range(len(result.t))
            if modes.side[j] == 2 and modes.event[j] in kinds]


def ratio_of(reaction: rx.Reaction, what: str) -> float:
    R, T = reaction.R[0], reaction.T[0]
    top = {"slip": math.hypot(R[0], R[1]), "spin": abs(T[2]),
           "roll": math.hypot(T[0], T[1])}[what]
    return top / R[2]


# ---- the independent reaction against the tests' own formulation ------------------------
def test_the_independent_reaction_is_the_tests_newton_euler():
    """reaction.solve on random states (any attitude, spin and law; S and its rate from
    the sphere's support map) against tests/newton_euler_friction.py: sticking, sliding
    along a direction, and with couples the wrench that holds the spin and the rolling
    (the residuals a_S = 0 and A w' = 0 of the held channels under it)."""
    rng = np.random.default_rng(36)
    scene = simulate(sphere(["0", "0", "0"], mu=0.7, mu_s=0.05, mu_r=0.04,
                            duration=1e-3)).scene
    b = rx.Bodies.of(scene)
    p = [M, m, J, J, J, G]
    for _ in range(40):
        A = rotation_from_quaternion(rng.normal(size=4))
        q = np.concatenate([rng.normal(size=3), rng.normal(size=3), rng.normal(0, 2, 3),
                            A.ravel()])
        u = np.concatenate([rng.normal(0, 0.2, 3), rng.normal(0, 1, 3), rng.normal(0, 5, 3)])
        k = rx.kinematics(b, q[None], u[None])
        n = A[2]
        assert np.allclose(k.s[0], -RADIUS * n)
        assert np.allclose(k.sd[0], -RADIUS * np.cross(n, q[6:9]), atol=1e-9)
        one = np.ones(1, dtype=bool)
        _, R_ne, _ = ne.sticking(q, u, k.s[0], k.sd[0], p)
        assert np.allclose(rx.solve(b, k, one).R[0], R_ne, rtol=1e-10, atol=1e-10)
        sigma = rng.normal(size=2)
        sigma /= np.linalg.norm(sigma)
        _, N_ne, _ = ne.sliding(q, u, k.s[0], k.sd[0], p, b.mu_f, sigma)
        got = rx.solve(b, k, ~one, sigma[None])
        assert got.N[0] == pytest.approx(N_ne, rel=1e-10, abs=1e-10)
        both = rx.solve(b, k, one, None, one, one)
        _, a_S, Wd = ne.under_wrench(q, u, k.s[0], k.sd[0], p, both.R[0], both.T[0])
        assert np.abs(a_S).max() < 1e-9 * (1.0 + np.abs(both.R[0]).max())
        assert np.abs(Wd).max() < 1e-9 * (1.0 + np.abs(both.T[0]).max())


# ---- the slip's stop: stick or slide on ------------------------------------------------------
@pytest.mark.parametrize("mu, want, band", [(MU_STICK, "stick", (0.985, 0.995)),
                                            (MU_REVERSE, "reversal", (1.005, 1.015))])
def test_a_stopping_slip_sticks_inside_the_cone_and_slides_on_outside_it(mu, want, band):
    """A sphere sliding at 5 cm/s while its point accelerates forward (pushing the body
    back): the slip stops where the sticking reaction needs 0.99 (or 1.01) mu_f N.  Inside
    the cone S sticks, and slips again exactly where |R_t| reaches mu_f N; outside it the
    slip restarts at once (a reversal), with no stick."""
    result = simulate(sphere(["0.5*t**2", "0", "0"], mu=mu, v0=(0.05, 0.0, 0.0)))
    first = decisions(result, ("stick", "reversal"))
    assert first, [e["kind"] for e in result.events]
    kind, j = first[0]
    ratio = ratio_of(held_reaction(result, j), "slip") / mu
    assert band[0] < ratio < band[1], f"the scene is off its boundary: {ratio:.4f}"
    assert kind == want, f"{kind} where |R_t| = {ratio:.4f} mu_f N"
    if want == "stick":
        ((_, j2),) = decisions(result, ("slip",))[:1]
        assert ratio_of(held_reaction(result, j2 - 1), "slip") / mu == pytest.approx(1.0,
                                                                                     abs=1e-6)
    else:
        assert not decisions(result, ("stick",))
    assert judge_run(result, RADIUS) == ("ok", "")


# ---- the couples' stops: held or turning on ------------------------------------------------
@pytest.mark.parametrize("what, mu_c, want, band", [
    ("spin", MU_S_HOLD, "spin_stop", (0.985, 0.995)),
    ("spin", MU_S_TURN, "spin_start", (1.005, 1.015)),
    ("roll", MU_R_HOLD, "roll_stop", (0.985, 0.995)),
    ("roll", MU_R_TURN, "roll_start", (1.005, 1.015))])
def test_a_stopping_couple_holds_inside_its_bound_and_turns_on_outside_it(what, mu_c, want,
                                                                          band):
    """A sphere stuck on the plane (mu_f = 1) spinning at 0.3 rad/s about the vertical (or
    rolling at 5 cm/s) while its point, off centre, accelerates: the spin (the rolling)
    stops where the couple that holds it needs 0.99 (or 1.01) of its bound.  Inside the
    bound the channel is held, and turns again exactly where its couple reaches the
    bound; outside it the channel turns on at once."""
    if what == "spin":
        doc = sphere(["0.5*t**2", "-0.1", "0"], omega=(0.0, 0.0, 0.3), mu_s=mu_c,
                     duration=0.6)
    else:
        doc = sphere(["1.0*t**2", "0", "0"], v0=(0.05, 0.0, 0.0), omega=(0.0, 0.1, 0.0),
                     mu_r=mu_c, duration=0.5)
    result = simulate(doc)
    events = decisions(result, (f"{what}_stop", f"{what}_start"))
    assert events, [e["kind"] for e in result.events]
    kind, j = events[0]
    ratio = ratio_of(held_reaction(result, j), what) / mu_c
    assert band[0] < ratio < band[1], f"the scene is off its boundary: {ratio:.4f}"
    assert kind == want, f"{kind} where |T| = {ratio:.4f} mu N"
    if want.endswith("_stop"):
        starts = decisions(result, (f"{what}_start",))
        assert starts, "the held couple never reached its bound"
        assert ratio_of(held_reaction(result, starts[0][1] - 1), what) / mu_c == \
            pytest.approx(1.0, abs=1e-6)
    assert judge_run(result, RADIUS) == ("ok", "")


# ---- lift-off ------------------------------------------------------------------------------
@pytest.mark.parametrize("excess", [1.01, 0.99])
def test_a_sphere_driven_up_and_down_lifts_off_where_n_reaches_zero(excess):
    """The point on the vertical through the centre, z = A sin(w t): the body stays at
    rest while stuck and N = (m+M) g + m z'' (the closed form; R_t = 0).  With m A w^2 =
    1.01 (m+M) g, N reaches 0 at t* = asin(1/1.01)/w and S lifts off there; with 0.99, N
    stays above 0.01 (m+M) g and S stays on the plane for the whole period."""
    w = 10.0
    A = excess * (M + m) * G / (m * w * w)
    result = simulate(sphere(["0", "0", f"{A!r}*sin({w!r}*t)"], mu=0.5,
                             duration=2 * math.pi / w))
    modes = rx.row_modes(result)
    rows = np.flatnonzero(modes.mode == rx.STICKING)
    b = rx.Bodies.of(result.scene)
    k = rx.kinematics(b, result.model_q[rows], rx.law_rows(result.scene, result.t[rows]))
    N = rx.solve(b, k, np.ones(len(rows), dtype=bool)).N
    closed = (M + m) * G - m * A * w * w * np.sin(w * result.t[rows])
    assert np.abs(N - closed).max() < 1e-10 * (M + m) * G
    lift = [e["t"] for e in result.events if e["kind"] == "lift_off"]
    if excess > 1.0:
        assert lift and lift[0] == pytest.approx(math.asin(1.0 / excess) / w, abs=1e-9)
    else:
        assert not lift and result.min_normal > 0.0099 * (M + m) * G
    assert judge_run(result, RADIUS) == ("ok", "")


# ---- the judge fails where it must --------------------------------------------------------
def test_the_judge_refuses_a_stick_outside_the_cone_and_a_slip_inside_it():
    """The judge of the rough plane against doctored event lists: the reversal at 1.01
    mu_f N told as a stick (the stick's own row outside the cone, as the mutant that
    accepted sticking up to 1.05 mu_f N made it), and the stick at 0.99 told as a
    reversal (a slip restarted where the cone held)."""
    for mu, was, told, why in ((MU_REVERSE, "reversal", "stick", "|R_t| - mu_f N"),
                               (MU_STICK, "stick", "reversal", "inside the cone")):
        result = simulate(sphere(["0.5*t**2", "0", "0"], mu=mu, v0=(0.05, 0.0, 0.0)))
        events = [dict(e) for e in result.events]
        k = next(i for i, e in enumerate(events) if e["kind"] == was)
        events[k].update(kind=told, mode="sticking" if told == "stick" else "sliding")
        result.__dict__["events"] = events
        for name in ("modes", "couples"):
            result.__dict__.pop(name, None)
        verdict, detail = judge_run(result, RADIUS)
        assert verdict == "cone" and why in detail, (verdict, detail)


# ---- an impact's stages at 3 % of each other ------------------------------------------------
def _impact_session(mu: float, e: float, law: str):
    from derive import abi
    from derive.runtime.build import library
    from derive.runtime.driver import Session, prepare
    prep = prepare(sphere(["0", "0", "0"], mu=mu, duration=1.0))
    s = Session(library(prep.kind), chunk=16)
    s.set_law(prep.scene.law)
    prm = prep.parameters.copy()
    prm[abi.PRM["e"]] = e
    prm[abi.PRM["restitution_model"]] = abi.index(abi.RESTITUTION_MODELS, law)
    s.init(prep.options, prm, prep.scene.t0, prep.start.q0)
    return s


@pytest.mark.parametrize("law", ["energetic", "poisson"])
@pytest.mark.parametrize("near, factor", [("compression", 0.97), ("compression", 1.03),
                                          ("end", 0.97), ("end", 1.03)])
def test_an_impacts_slip_stops_three_percent_before_or_after_compression_or_restitution_ends(
        near, factor, law):
    """W couples the slip along X with the normal impulse (W_XZ != 0; the slip keeps its
    direction, a ray, and sticks after it stops, |tau| < mu_f): while slipping
    dv_n/dp = W_ZZ - mu_f W_XZ, compression would end at p_c = -v_n/(W_ZZ - mu_f W_XZ)
    and restitution at (1 + e) p_c (both laws at constant rates); the slip speed falls
    as rho0 - (mu_f W_XX - W_XZ) p.  With its stop at 0.97 and 1.03 of p_c, and of the
    end's (1 + e) p_c after p_c (p_c + 0.97 e p_c, p_c + 1.03 e p_c: the impact decides on
    what remains of each stage), each stage boundary lies 3 % from the next, where the
    sticking rates (dv_n/dp = W_ZZ - W_XZ^2/W_XX) differ from the slip's: the impulse,
    the velocity after, the works and the stage against derive/darboux_keller.py
    (SciPy's DOP853 on the slip, closed forms on the stick) to 1e-9."""
    from derive import darboux_keller as dk
    W = np.array([[0.8, 0.0, 0.25], [0.0, 0.6, 0.0], [0.25, 0.0, 1.3]])
    mu, e, v_n = 0.5, 0.6, -2.0
    p_c = -v_n / (W[2, 2] - mu * W[0, 2])
    p_s = factor * p_c if near == "compression" else p_c * (1.0 + factor * e)
    v0 = np.array([(mu * W[0, 0] - W[0, 2]) * p_s, 0.0, v_n])
    s = _impact_session(mu, e, law)
    status, out = s.impact(W, v0)
    ref = dk.integrate(W, v0, mu, e, law)
    assert status == "ok"
    events = [what for _, what in ref.events]
    stops = "slip stops" in events
    assert stops == (near == "compression" or factor < 1.0), events
    assert np.abs(out["impulse"] - ref.impulse).max() < 1e-9 * ref.impulse[2]
    assert np.abs(out["v_plus"] - ref.v_plus).max() < 1e-9 * abs(v_n)
    scale = abs(v_n) * ref.impulse[2]
    assert out["work_normal"] == pytest.approx(ref.work_normal, abs=1e-9 * scale)
    assert out["work_friction"] == pytest.approx(ref.work_friction, abs=1e-9 * scale)
    assert out["stage"] == (1 if stops else 0)


# ---- where sliding gives up: Painleve's jam ---------------------------------------------------
JAM = {"name": "jam",
       "body": {"mass": 0.6944530848494009, "shape": "sphere", "radius": 0.36814160696756915,
                "inertia": [0.016129301500455016, 0.016116128758682836, 0.01612971053121029],
                "center": [0.06547794925807958, -0.08591019271603494, -0.081752662216688]},
       "point": {"mass": 0.05482719085974788,
                 "law": ["-0.0269348*sin(1.77475*t + 1.02705)",
                         "0.0189423*sin(7.50012*t + 1.5498)",
                         "0.0163953*sin(12.8533*t + 0.420078)"]},
       "plane": {"restitution": 0.0, "friction": 1.288950170670899,
                 "restitution_model": "poisson"},
       "initial": {"com": [0.0, 0.0, 0.4587907019507393],
                   "com_velocity": [0.766909387652072, 0.4323227299013967, 0.0],
                   "omega": [3.935339957931003, 0.6775454112131721, -1.4445748688407503],
                   "quaternion": [1.5215226725907989, 0.8128832573724393, -0.5143997529961658,
                                  -0.3501503752456439]},
       "run": {"duration": 0.1, "method": "dopri5", "rtol": 6.084149130799884e-09,
               "atol": 1e-12}}


def test_sliding_into_painleves_jam_stops_where_n_passes_a_hundred_weights():
    """An offset sphere (scene #20 of derive verify robustness --plane rough) lands sliding
    with mu_f = 1.29, and N's coefficient k_f = W_ZZ - mu_f (W_Zt, dir) falls towards 0
    as it slides: N = -a_free/k_f grows without bound, a jam only an impact resolves.  The
    runtime gives up (status painleve) once k_f <= 1e-2 W_ZZ with N above 100 weights: its
    last row, the step before, has k_f below 1e-2 W_ZZ and N between 60 and 100
    weights, growing by at most a fifth per step (N and W by Newton-Euler, apart from the
    runtime: derive/verify/reaction.py, tests/newton_euler_friction.py)."""
    result = simulate(JAM)
    assert result.status == "painleve"
    s = result.scene
    weight = (s.M + s.m) * s.g
    b = rx.Bodies.of(s)
    N, kf = [], []
    for j in range(len(result.t) - 3, len(result.t)):
        k = rx.kinematics(b, result.model_q[[j]], rx.law_rows(s, result.t[[j]]))
        slip = k.v_S[0, :2] / np.hypot(*k.v_S[0, :2])
        N.append(rx.solve(b, k, np.zeros(1, dtype=bool), slip[None]).N[0] / weight)
        W = ne.inverse_inertia_at_S(result.model_q[j], rx.law_rows(s, result.t[[j]]).points[0, 0],
                                    k.s[0], [s.M, s.m, *s.J, s.g])
        kf.append((W[2, 2] - s.friction * (W[2, :2] @ slip)) / W[2, 2])
    assert kf[-1] <= 1e-2 < kf[0]
    assert 60.0 < N[-1] < 100.0 and N[-1] / N[-2] < 1.25, N

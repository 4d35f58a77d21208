"""Spin (drilling) friction and rolling resistance: the rough plane's contact couples.

The contact's reaction becomes a wrench (R, T) at S with |T_Z| <= mu_s N and
|(T_X, T_Y)| <= mu_r N (derive/friction.py: contact_wrench; the runtime solves each
mode's unknowns on G and a_free, crt_friction.h).  Checked against:

* an independent Newton–Euler formulation (tests/newton_euler_friction.py, which adds the
  couple to the carrier's Euler equation): G, a_free and the rates under a wrench, on
  random states;
* closed forms: a sphere spinning on its contact point stops at t* = J w0/(mu_s N),
  its spin falling linearly; a ball rolling without slip decelerates at
  mu_r g/(R (1 + J/((m+M) R^2))) (5/7 mu_r g/R for a homogeneous ball) and stops, and
  the energy balance puts the whole loss on friction;
* a body held from rolling (a flat foot: rolling resistance that never lets go) sliding
  on the plane under the point moving on a vertical circle, the setting of Bardin and
  Panev (2018): its stick-slip motion against a 1-D Coulomb model integrated by SciPy;
* random rough scenes with couples through the robustness judge (the cones of the force
  and of both couples, friction's work, the energy balance).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import newton_euler_friction as ne
from cases import rotation_from_quaternion
from derive.emit.numpy_backend import numpy_function
from derive.runtime.driver import simulate
from derive.runtime.motion import energy_balance, motion
from derive.scene import SceneError, parse_scene

G = 9.81


def _random_state(rng):
    A = rotation_from_quaternion(rng.normal(size=4))
    q = np.concatenate([rng.normal(size=3), rng.normal(size=3), rng.normal(0, 2, 3),
                        A.ravel()])
    u = np.concatenate([rng.normal(0, 0.2, 3), rng.normal(0, 1, 3), rng.normal(0, 5, 3)])
    s, sdot = rng.normal(0, 0.3, 3), rng.normal(0, 0.5, 3)
    J = rng.uniform(0.2, 1.0, 3)
    J[2] = min(J[2], J[0] + J[1])
    return q, u, s, sdot, np.array([rng.uniform(0.5, 3), rng.uniform(0.05, 2), *J, G])


def _full(g21):
    Gm = np.zeros((6, 6))
    Gm[np.triu_indices(6)] = g21
    return Gm + np.triu(Gm, 1).T


def test_the_wrench_equations_are_newton_eulers():
    """On 200 random states and wrenches: dq/dt under the wrench (by a solve, and by the
    runtime's omega' = omega_free + omega_per_wrench (R, T) without one), and du/dt =
    a_free + G (R, T) for u = (v_S, A omega), both as the Newton–Euler formulation gives
    them; G
    is symmetric (its lower triangle, from the rates, equals the upper one emitted) and
    positive definite, and its force block is the Delassus matrix."""
    wrench_of = numpy_function("general_contact_wrench")
    rhs_of = numpy_function("general_wrench_rhs")
    rates_of = numpy_function("general_wrench_rates")
    delassus = numpy_function("general_delassus")
    rng = np.random.default_rng(41)
    for _ in range(200):
        q, u, s, sdot, p = _random_state(rng)
        g21, a_free, u6, w0, Yw = wrench_of(q, u, s, sdot, p)
        Gm = _full(g21)
        w = rng.normal(0, 5, 6)
        (dq,) = rhs_of(q, u, s, p, w)
        # the runtime's route: omega' = w0 + Yw w, then the rates without a solve
        (dq_rates,) = rates_of(q, p, w0 + Yw.reshape(6, 3).T @ w, w[:3])
        assert np.abs(dq_rates - dq).max() < 1e-12 * (np.abs(dq).max() + 1)
        dq_ne, aS_ne, Wd_ne = ne.under_wrench(q, u, s, sdot, p, w[:3], w[3:])
        scale = np.abs(dq_ne).max() + 1.0
        assert np.abs(dq - dq_ne).max() < 1e-11 * scale
        rates = a_free + Gm @ w
        assert np.abs(rates - np.r_[aS_ne, Wd_ne]).max() < 1e-10 * (np.abs(rates).max() + 1)
        # the lower triangle from the rates of unit wrenches: Maxwell's reciprocity
        cols = np.array([ne.under_wrench(q, u, s, sdot, p, e[:3], e[3:])
                         for e in np.eye(6)], dtype=object)
        lower = np.array([np.r_[c[1], c[2]] for c in cols]).T - np.r_[
            ne.under_wrench(q, u, s, sdot, p, np.zeros(3), np.zeros(3))[1:]].reshape(6, 1)
        assert np.abs(lower - Gm).max() < 1e-10 * np.abs(Gm).max()
        assert np.linalg.eigvalsh(Gm).min() > 0.0
        W, v_S = delassus(q, u, s, p)
        assert np.abs(Gm[:3, :3][np.triu_indices(3)] - W).max() < 1e-12 * np.abs(W).max()
        assert np.abs(u6[:3] - v_S).max() < 1e-12 * (np.abs(v_S).max() + 1)
        assert np.abs(u6[3:] - q[9:18].reshape(3, 3) @ q[6:9]).max() < 1e-12 * scale


def sphere(M, m, J, R, V, omega, mu=0.5, mu_s=0.0, mu_r=0.0, duration=2.0):
    return {"name": "sphere", "body": {"mass": M, "inertia": [J, J, J], "shape": "sphere",
                                       "radius": R},
            "point": {"mass": m, "law": ["0", "0", "0"]},
            "plane": {"restitution": 0.0, "friction": mu, "spin_friction": mu_s,
                      "rolling_resistance": mu_r},
            "initial": {"com": [0.2, -0.1, R], "com_velocity": list(V), "omega": list(omega)},
            "run": {"duration": duration, "method": "dop853", "rtol": 1e-12, "atol": 1e-13,
                    "outputs": ["pose", "impacts"]}}


def test_a_spinning_sphere_stops_at_the_closed_form_time():
    """omega_Z(t) = w0 - mu_s (m+M) g t/J until t* = J w0/(mu_s (m+M) g), 0 after;
    the drilling couple holds it there (spin_stop, the spin channel held)."""
    rng = np.random.default_rng(5)
    for _ in range(5):
        M, m, R = rng.uniform(0.5, 3), rng.uniform(0.05, 1), rng.uniform(0.05, 0.3)
        J = rng.uniform(0.2, 0.7) * (M + m) * R * R
        w0, mu_s = rng.uniform(-8, 8), rng.uniform(0.05, 0.5) * R
        t_star = J * abs(w0) / (mu_s * (M + m) * G)
        res = simulate(sphere(M, m, J, R, [0, 0, 0], [0, 0, w0], mu_s=mu_s,
                              duration=1.5 * t_star))
        assert res.status == "done"
        kinds = [e["kind"] for e in res.events]
        assert kinds[-1] == "spin_stop" and "spin_start" not in kinds, kinds
        t0, stop = res.events[kinds.index("contact")]["t"], res.events[-1]
        assert stop["t"] - t0 == pytest.approx(t_star, abs=1e-10 * (1 + t_star))
        assert stop["couples"] == 1 and 0.0 <= stop["value"] <= 1.0
        A = res.q[:, 9:18].reshape(-1, 3, 3)
        spin = np.einsum("nj,nj->n", A[:, 2], res.q[:, 6:9])
        before = (res.t > t0) & (res.t < stop["t"])
        want = np.sign(w0) * (abs(w0) - mu_s * (M + m) * G * (res.t[before] - t0) / J)
        assert np.abs(spin[before] - want).max() < 1e-9 * abs(w0)
        assert np.abs(spin[res.t > stop["t"]]).max() < 1e-12 * abs(w0)


@pytest.mark.parametrize("k", [0.4, 0.25])
def test_a_rolling_ball_decelerates_at_the_closed_form_rate(k):
    """J = k (m+M) R^2, rolling without slip at v0: V' = -mu_r g/(R (1 + k)), so it stops
    at t* = v0 R (1 + k)/(mu_r g) (5/7 mu_r g/R for k = 2/5) and stays; the slip stays
    0 (the force inside its cone), and the energy balance puts the whole kinetic energy
    on friction's work."""
    M, m, R, v0, mu_r = 1.0, 0.3, 0.1, 1.0, 0.01
    J = k * (M + m) * R * R
    rate = mu_r * G / (R * (1 + k))
    res = simulate(sphere(M, m, J, R, [v0, 0, 0], [0, v0 / R, 0], mu_r=mu_r,
                          duration=v0 / rate + 0.3))
    assert res.status == "done"
    kinds = [e["kind"] for e in res.events]
    assert kinds[-2:] == ["contact", "roll_stop"], kinds
    t0, stop = res.events[-2]["t"], res.events[-1]
    assert stop["t"] - t0 == pytest.approx(v0 / rate, abs=1e-9)
    assert stop["mode"] == "sticking" and stop["couples"] == 2
    rolling = (res.t > t0) & (res.t < stop["t"])
    assert np.abs(res.q[rolling, 3] - (v0 - rate * (res.t[rolling] - t0))).max() < 1e-9
    assert np.abs(res.q[res.t > stop["t"], 3:6]).max() < 1e-12
    assert np.abs(res.slip).max() < 1e-12
    balance = energy_balance(res, motion(res))
    E0 = 0.5 * (M + m) * v0 ** 2 * (1 + k)
    assert balance["change"] == pytest.approx(-E0, rel=1e-9)
    assert balance["work_of_friction"] == pytest.approx(-E0, rel=1e-8)
    assert abs(balance["residual"]) < 1e-8 * E0


# ---- a body that cannot roll, sliding on the plane: Bardin and Panev's setting -------------
def _foot(mu_r, mu=0.3, u0=0.0, duration=1.5):
    """A sphere of radius 0.1 whose rolling resistance and spin friction act as a flat
    foot of half-width mu_r; the point (m = 0.3) on the circle x = r cos(w t),
    z = r sin(w t) about O, with O at rest at the start."""
    M, m, R, r, w = 1.0, 0.3, 0.1, 0.05, 20.0
    doc = {"name": "foot", "body": {"mass": M, "inertia": [0.4 * M * R * R] * 3,
                                    "shape": "sphere", "radius": R},
           "point": {"mass": m, "law": [f"{r}*cos({w}*t)", "0", f"{r}*sin({w}*t)"]},
           "plane": {"restitution": 0.0, "friction": mu, "rolling_resistance": mu_r,
                     "spin_friction": mu_r},
           "initial": {"com": [m * r / (M + m), 0, R],
                       "com_velocity": [u0, 0, m * r * w / (M + m)]},
           "run": {"duration": duration, "method": "dop853", "rtol": 1e-11, "atol": 1e-13,
                   "outputs": ["pose", "impacts"]}}
    return doc, (M, m, r, w, mu)


def _coulomb_1d(M, m, r, w, mu, t0, u0, T):
    """The body's velocity u along X (no rotation, N = (M+m) g + m z''): (M+m) u' =
    F - m x''(t), F = -mu N sign(u) while sliding; u = 0 held while |m x''| <= mu N.
    Integrated phase by phase with SciPy's DOP853 and its events; returns the dense
    pieces and the times where u reaches 0."""
    xdd = lambda t: -r * w * w * np.cos(w * t)                   # noqa: E731
    N = lambda t: (M + m) * G - m * r * w * w * np.sin(w * t)  # noqa: E731
    t, u, pieces, stops = t0, u0, [], []
    while t < T - 1e-12:
        if u == 0.0 and abs(m * xdd(t)) <= mu * N(t) * (1 - 1e-12):
            cone = lambda tt, y: mu * N(tt) - abs(m * xdd(tt))  # noqa: E731
            cone.terminal, cone.direction = True, -1
            sol = solve_ivp(lambda tt, y: [0.0], (t, T), [0.0], events=cone, rtol=1e-13,
                            atol=1e-15, max_step=1e-3, dense_output=True)
            pieces.append(sol)
            t = sol.t[-1]
            continue
        sgn = np.sign(u) if u != 0.0 else (1.0 if -m * xdd(t) > 0 else -1.0)
        stop = lambda tt, y: y[0]                                   # noqa: E731
        stop.terminal, stop.direction = True, -sgn
        sol = solve_ivp(lambda tt, y: [(-m * xdd(tt) - mu * N(tt) * sgn) / (M + m)], (t, T),
                        [u], method="DOP853", events=stop, rtol=1e-13, atol=1e-15,
                        dense_output=True)
        pieces.append(sol)
        t = sol.t[-1]
        u = 0.0 if sol.status == 1 else sol.y[0, -1]
        if sol.status == 1:
            stops.append(t)
    return pieces, stops


def test_a_body_held_from_rolling_slides_as_the_one_dimensional_coulomb_model():
    """Rolling resistance large enough never lets the body turn: it slides without
    rotation, the setting of Bardin and Panev (2018) for a body with a point moving on a
    circle in a vertical plane.  Its velocity and the times its slip stops (stick or
    reversal) agree with an independent 1-D Coulomb model to 1e-8; after the first period
    the motion repeats with the point's period (the periodic mode, drifting)."""
    doc, (M, m, r, w, mu) = _foot(0.05)
    res = simulate(doc)
    assert res.status == "done"
    kinds = [e["kind"] for e in res.events]
    assert "roll_start" not in kinds and kinds.count("roll_stop") == 1
    stop = res.events[kinds.index("roll_stop")]
    A = res.q[:, 9:18].reshape(-1, 3, 3)
    Om = np.einsum("nij,nj->ni", A, res.q[:, 6:9])[res.t > stop["t"]]
    assert np.abs(Om).max() < 1e-12                 # held from rolling and spinning
    t0 = stop["t"]
    i0 = int(np.searchsorted(res.t, t0, side="right"))
    u_rt = res.q[:, 3] - m / (M + m) * (-r * w * np.sin(w * res.t))     # O's velocity
    pieces, stops = _coulomb_1d(M, m, r, w, mu, t0, float(u_rt[i0 - 1]), res.t[-1])
    events = [e["t"] for e in res.events if e["kind"] in ("stick", "reversal")]
    assert len(events) == len(stops) >= 8
    assert np.abs(np.array(events) - stops).max() < 1e-8
    ends = np.array([p.t[-1] for p in pieces])
    for k in range(i0, len(res.t)):
        p = pieces[min(int(np.searchsorted(ends, res.t[k])), len(pieces) - 1)]
        assert abs(u_rt[k] - p.sol(res.t[k])[0]) < 1e-8
    sticks = [e["t"] for e in res.events if e["kind"] == "stick"]
    assert len(sticks) >= 4       # the first period is a transient, then the mode repeats
    assert np.abs(np.diff(sticks)[1:] - 2 * np.pi / w).max() < 1e-8


def test_random_scenes_with_couples_keep_their_invariants():
    """60 random rough scenes with spin friction and rolling resistance (the robustness
    generator's) through its judge: no fall, the cones of the force and of both couples on
    every contact row, friction's work never positive, no energy gained beyond the drive's
    work; honest painleve stops only."""
    from derive.verify.generators import random_rough_scene
    from derive.verify.judges import judge_run
    rng = np.random.default_rng(2026)
    verdicts = []
    for _ in range(60):
        doc = random_rough_scene(rng, max_duration=4.0, couples=True)
        res = simulate(doc)
        size = doc["body"].get("radius") or max(doc["body"]["semi_axes"])
        verdict, detail = judge_run(res, size)
        assert verdict in ("ok", "painleve"), (verdict, detail, doc["plane"])
        verdicts.append(verdict)
    assert verdicts.count("ok") >= 55


@pytest.mark.parametrize("key", ["spin_friction", "rolling_resistance"])
def test_a_couple_needs_friction_and_a_non_negative_length(key):
    doc = sphere(1.0, 0.2, 0.004, 0.1, [0, 0, 0], [0, 0, 0], mu=0.0, **{
        "mu_s" if key == "spin_friction" else "mu_r": 0.01})
    with pytest.raises(SceneError, match=rf"\[plane\]\.{key}: needs \[plane\]\.friction > 0"):
        parse_scene(doc)
    doc["plane"]["friction"] = 0.3
    doc["plane"][key] = -0.01
    with pytest.raises(SceneError, match=rf"\[plane\]\.{key}"):
        parse_scene(doc)


# the kinds of events in one period of each periodic mode (the point's period 2 pi/w)
MODES_OF_MOTION = {
    0.1: ["reversal", "reversal"],                  # moves both ways, never rests
    0.3: ["stick", "slip", "reversal"],             # rests once, reverses once
    0.4: ["stick", "slip", "stick", "slip"],        # rests at both stops
}


@pytest.mark.parametrize("mu", sorted(MODES_OF_MOTION))
def test_bardin_panevs_periodic_modes(mu):
    """Bardin and Panev (2018, abstract): a periodic mode always exists, of one of three
    types depending on the parameters, and from any initial velocity the body enters it
    in finite time or approaches it.  Three kinds appear here as mu_f grows (no rest, one
    rest, two rests per period); from the initial velocities -0.4, 0 and 0.4 m/s the last
    period's events (kind and phase) are the same to 1e-7 of the period, and the runs
    agree with the 1-D Coulomb model throughout.  With rests the first one resets the
    motion (the mode is entered in finite time); without, it is approached (the phases
    2e-5 of the period apart after 3 s, 6e-11 after 6 s)."""
    w = 20.0
    period = 2 * np.pi / w
    duration = 6.0 if "stick" not in MODES_OF_MOTION[mu] else 3.0
    last = []
    for u0 in (-0.4, 0.0, 0.4):
        doc, (M, m, r, w, _) = _foot(0.1, mu=mu, u0=u0, duration=duration)
        res = simulate(doc)
        assert res.status == "done"
        kinds = [e["kind"] for e in res.events]
        assert "roll_start" not in kinds and "spin_start" not in kinds
        t0 = max(e["t"] for e in res.events if e["kind"] in ("roll_stop", "contact"))
        i0 = int(np.searchsorted(res.t, t0, side="right"))
        u = res.q[:, 3] - m / (M + m) * (-r * w * np.sin(w * res.t))
        _, stops = _coulomb_1d(M, m, r, w, mu, t0, float(u[i0 - 1]), res.t[-1])
        ends = [e["t"] for e in res.events if e["kind"] in ("stick", "reversal")]
        assert len(ends) == len(stops) and np.abs(np.array(ends) - stops).max() < 1e-7
        tail = [(e["kind"], e["t"]) for e in res.events
                if e["t"] > duration - period and e["kind"] in ("stick", "slip", "reversal")]
        phases = sorted(((t % period) / period, k) for k, t in tail)
        assert sorted(k for _, k in phases) == sorted(MODES_OF_MOTION[mu]), phases
        last.append(phases)
    for other in last[1:]:
        assert [k for _, k in other] == [k for _, k in last[0]]
        assert np.abs(np.array([p for p, _ in other]) - [p for p, _ in last[0]]).max() < 1e-7


def test_the_cli_names_each_couples_stops_and_a_refused_build_in_one_line(tmp_path, capsys,
                                                                        monkeypatch):
    """`derive simulate` says which couple stopped and when (the spinning sphere above);
    and a runtime the C compiler refuses (a bug in derive, not in the input) is one line
    on stderr with exit status 1, not a traceback."""
    import json

    from derive.cbuild import BuildError
    from derive.cli import main
    from derive.runtime import driver
    doc = sphere(1.0, 0.3, 0.4 * 1.3 * 0.01, 0.1, [0, 0, 0], [0, 0, 5.0], mu_s=0.01,
                 duration=0.5)
    from derive.scene import toml
    path = tmp_path / "spin.toml"
    path.write_text(toml.dumps(doc))
    assert main(["simulate", str(path), "-o", str(tmp_path / "out"), "--no-plots"]) == 0
    out = capsys.readouterr().out
    t_star = 0.4 * 1.3 * 0.01 * 5.0 / (0.01 * 1.3 * G)
    line = next(ln for ln in out.splitlines() if ln.strip().startswith("couples:"))
    assert "spin 1 stop, 0 starts" in line and "rolling 0 stops" in line, line
    assert f"{t_star:.4f}"[:5] in line, (line, t_star)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())["contact"]
    assert summary["spin_friction"] == 0.01 and summary["time_rolling_held"] == 0.0
    header = (tmp_path / "out" / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert header[-1] == "couples"

    def refused(kind):
        raise BuildError("the C compiler rejected the generated code:\n"
                         "x.c:1:2: error: something")
    monkeypatch.setattr(driver, "session_for", refused)
    assert main(["simulate", str(path), "-o", str(tmp_path / "out2")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "first error: x.c:1:2: error: something" in err[0], err
    assert "Traceback" not in err[0]

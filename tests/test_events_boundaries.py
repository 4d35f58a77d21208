"""The flight's decisions at a plane (crt_events.h's crt_collide) at 2 % of their thresholds.

Each scene puts one decision within 2 % of its bound, on either side, so that a bound off
by a few percent changes an asserted outcome (``derive verify mutants`` checks that it
does).  The scene is the classical ball (a sphere with its point fixed at its centre,
tests/test_runtime.py's ``ball``), whose flights are a closed form: dropped from H, it
lands at v1 = sqrt(2 g H), and after its k-th impact it leaves at e^k v1, rises
e^(2k) H and flies 2 e^k v1 / g; the flights left after it sum to 2 e^k v1 / (g (1 - e)).

* impacts accumulate: the runtime enters contact after the impact whose remaining
  flights sum to less than zeno_dt x duration; zeno_dt is set so that after the K-th
  they sum to 0.98 of it (contact after K impacts) or 1.02 of it (after K + 1), for
  e = 0.5 and for e = 0.96 (the ratio of successive flights within 5 % of 1);
* with the point driven along the vertical, a = -g - nu z''(t) changes from hop to hop,
  and the ratio r of the geometric series is measured from successive flights (the
  next hop's 2 v+/|a| over the last flight; derive/docs/runtime.md): zeno_dt is set so
  that the flights left after the K-th impact, tau/(1 - r), are 0.98 or 1.02 of the
  threshold, the impacts computed apart from the runtime (C's parabolas and the law's
  roots, by SciPy's brentq); r = e there would move them by 7 %;
* or whose rise is below the height resolution h_res (derive/docs/runtime.md: ten times
  atol + rtol (|Z_C| + L)): H is set so that the K-th rise is 0.98 or 1.02 of it;
* a start on the plane moving down at 0.98 of the speed below which a normal speed is
  round-off (1e3 eps (|Z_C'| + sqrt(g L)) for the ball) touches the plane and rests on it
  at once, with no impact; at 1.02 of it, it is an impact first;
* a start put on the plane (the option start_on_plane) begins in contact where S rests
  within the height resolution above the plane and leaves it slower than the speed
  noise: at 0.98 of either, the contact at t0; at 1.02, a flight first.

And the search's own decision: a dip of S below the plane shorter than the spacing of
its samples (S comes down and goes up again between two of them, both above the plane)
is found by the cubic through their heights and rates, subdivided; the first crossing
is the closed form's.

The count of impacts before contact and the time of entry are the closed form's; each
test also asserts that its scene's decision falls in its band.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from derive import abi
from derive.runtime.driver import options, simulate
from derive.scene import load
from test_runtime import ball, scene_dict

G, R = 9.81, 0.5
EPS = np.finfo(float).eps
RTOL, ATOL = 1e-10, 1e-12


def run(e: float, H: float, duration: float, law=("0", "0", "0"), **extra):
    doc = ball(e=e, z0=R + H, duration=duration, rtol=RTOL, atol=ATOL, method="dopri5",
               law=law, **extra)
    res = simulate(doc, progress=False)
    assert res.status == "done" and res.model == "translational"
    return res


def entry(res) -> tuple[int, float]:
    """(impacts before the runtime entered contact, the time it did)."""
    contact = [ev for ev in res.events if ev["kind"] == "contact"]
    assert len(contact) == 1, [ev["kind"] for ev in res.events]
    t = contact[0]["t"]
    return int(np.sum(res.impacts[:, 0] <= t)), t


def impact_times(e: float, H: float, n: int) -> np.ndarray:
    v1 = math.sqrt(2 * G * H)
    flights = [math.sqrt(2 * H / G)] + [2 * e ** k * v1 / G for k in range(1, n)]
    return np.cumsum(flights)


@pytest.mark.parametrize("e, K, duration", [(0.5, 6, 3.0), (0.96, 60, 20.0)])
@pytest.mark.parametrize("band", [0.98, 1.02])
def test_accumulating_impacts_enter_contact_where_the_flights_left_reach_zeno_dt(
        e, K, duration, band):
    H = 0.5
    remaining = 2 * e ** K * math.sqrt(2 * G * H) / (G * (1 - e))
    zeno_dt = remaining / (band * duration)
    res = run(e, H, duration, zeno_dt=zeno_dt)
    n, t = entry(res)
    expected = K if band < 1 else K + 1
    assert n == expected and len(res.impacts) == expected
    # the decision's band, from the run's own K-th impact: the flights left after it
    left = 2 * res.impacts[K - 1, 3] / (G * (1 - e))
    assert abs(left / (zeno_dt * duration) - band) < 1e-6
    np.testing.assert_allclose(res.impacts[:, 0], impact_times(e, H, expected),
                               rtol=0, atol=1e-8)
    assert t == res.impacts[-1, 0]


def driven_impacts(e, Z0, A, W, n) -> np.ndarray:
    """(t, v_n-, v_n+) of the first n impacts of the ball whose point moves at z = A sin(W t)
    along the vertical, apart from the runtime: C falls on parabolas (Z_C'' = -g), S is
    at Z_C - nu z - R, Newton's law at each impact."""
    from scipy.optimize import brentq
    nu = 0.2 / 1.2
    t0, Zc, Vc, out = 0.0, Z0, 0.0, []
    for k in range(n):
        def h(t, t0=t0, Zc=Zc, Vc=Vc):
            return Zc + Vc * (t - t0) - 0.5 * G * (t - t0) ** 2 - nu * A * math.sin(W * t) - R
        a, dt = t0 + (1e-9 if k else 0.0), 1e-4
        while h(a + dt) > 0:
            a += dt
        t = brentq(h, a, a + dt, xtol=1e-15, rtol=4 * EPS)
        vm = Vc - G * (t - t0) - nu * A * W * math.cos(W * t)
        out.append((t, vm, -e * vm))
        t0, Zc, Vc = t, h(t) + nu * A * math.sin(W * t) + R, -e * vm + nu * A * W * math.cos(W * t)
    return np.array(out)


@pytest.mark.parametrize("band", [0.98, 1.02])
def test_the_ratio_of_flights_is_measured_where_the_pull_changes_from_hop_to_hop(band):
    e, A, W, K, duration = 0.5, 0.1, 10.0, 3, 3.0
    nu = 0.2 / 1.2
    imp = driven_impacts(e, R + 0.5, A, W, K + 1)
    # the flights left after each impact: the next hop 2 v+/|a| with a = -g - nu z''(t),
    # over the last flight (e at the first impact), summed as a geometric series
    a = -G + nu * A * W ** 2 * np.sin(W * imp[:, 0])
    tau = 2 * imp[:, 2] / -a
    ratio = np.r_[e, tau[1:] / np.diff(imp[:, 0])]
    left = tau / (1 - ratio)
    assert abs(left[K - 1] / (tau[K - 1] / (1 - e)) - 1) > 0.05     # r = e would miss it
    zeno_dt = left[K - 1] / (band * duration)
    assert np.all(left[:K - 1] > zeno_dt * duration)
    res = run(e, 0.5, duration, zeno_dt=zeno_dt, law=["0", "0", f"{A}*sin({W}*t)"])
    n, t = entry(res)
    expected = K if band < 1 else K + 1
    assert n == expected
    np.testing.assert_allclose(res.impacts[:, 0], imp[:expected, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.impacts[:, 3], imp[:expected, 2], rtol=1e-7)


@pytest.mark.parametrize("band", [0.98, 1.02])
def test_impacts_enter_contact_where_the_rise_reaches_the_height_resolution(band):
    e, K = 0.5, 15
    probe = ball(e=e, rtol=RTOL, atol=ATOL, method="dopri5")
    L = options(load(probe)[0], "translational")[abi.OPT["length_scale"]]
    h_res = 10 * max(ATOL + RTOL * (R + L), 64 * EPS * (R + L))
    H = band * h_res / e ** (2 * K)
    t_inf = math.sqrt(2 * H / G) * (1 + 2 * e / (1 - e))
    # zeno_dt far below the flights left: the rise decides alone
    res = run(e, H, 1.2 * t_inf, zeno_dt=1e-15)
    n, t = entry(res)
    expected = K if band < 1 else K + 1
    assert n == expected
    # the decision's band, from the run's own K-th impact: the rise after it
    rise = res.impacts[K - 1, 3] ** 2 / (2 * G)
    assert abs(rise / h_res - band) < 1e-6
    np.testing.assert_allclose(res.impacts[:, 0], impact_times(e, H, expected),
                               rtol=1e-8, atol=0)


@pytest.mark.parametrize("band", [0.98, 1.02])
def test_a_start_moving_down_at_round_off_speed_touches_and_rests(band):
    L = R
    # v = band x 1e3 eps (v + sqrt(g L)): the runtime's speed noise of the ball at rest
    v = band * 1e3 * EPS * math.sqrt(G * L) / (1 - band * 1e3 * EPS)
    doc = ball(e=0.5, z0=R, duration=0.1, rtol=RTOL, atol=ATOL, method="dopri5")
    doc["initial"]["com_velocity"] = [0.0, 0.0, -v]
    res = simulate(doc, progress=False)
    assert res.status == "done"
    kinds = [(ev["kind"], ev["t"]) for ev in res.events]
    if band < 1:
        assert kinds == [("contact", 0.0)] and len(res.impacts) == 0
    else:
        assert kinds == [("impact", 0.0), ("contact", 0.0)] and len(res.impacts) == 1
        np.testing.assert_allclose(res.impacts[0, 2:], [-v, 0.5 * v], rtol=1e-6)
    assert res.stats["grazes"] == 0
    # resting: the ball's centre stays at R
    assert np.max(np.abs(res.q[:, 2] - R)) < 1e-12


def swing(delta: float, t0_before: float, step: float, duration_after: float = 0.01):
    """The ball whose point swings its centre down and up (z = A cos(W t), nu A W^2 > g),
    started at t_m - t0_before so that S's height is h(t) = nu A (1 - cos W t) - delta
    - g (t - t_m)^2 / 2 around t_m = 2 pi / W (C on the parabola Z_C'' = -g through
    R + nu A - delta at t_m, at rest there), run by RK4 with a fixed step; (result, h)."""
    nu, A, W = 0.2 / 1.2, 0.2, 40.0
    tm = 2 * math.pi / W
    t0 = tm - t0_before

    def h(t):
        return nu * A * (1 - math.cos(W * t)) - delta - 0.5 * G * (t - tm) ** 2
    doc = ball(e=0.5, z0=R + nu * A - delta - 0.5 * G * (t0 - tm) ** 2,
               law=("0", "0", f"{A}*cos({W}*t)"), duration=t0_before + duration_after,
               method="rk4", step=step)
    doc["initial"]["time"] = t0
    doc["initial"]["com_velocity"] = [0.0, 0.0, G * (tm - t0)]
    res = simulate(doc, progress=False)
    assert res.status == "done" and res.model == "translational"
    return res, h, tm


@pytest.mark.parametrize("where", [0.25, 0.0])
def test_a_near_miss_reports_its_least_height(where):
    """S passes 1 micrometre above the plane at t_m, one of the search's samples (a
    quarter of a fixed 4 ms step into it, or a step's end): no event, and the summary's
    least height of S is the closed form's 1e-6 m, not the least of the other samples
    (2e-5 m higher)."""
    step = 0.004
    res, h, tm = swing(-1e-6, 20 * step + where * step, step)
    assert len(res.impacts) == 0 and not res.events
    assert min(h(tm - step / 4), h(tm + step / 4)) > 1e-6 + 1e-5
    assert abs(res.min_height - 1e-6) < 1e-12
    assert abs(res.summary["t_min_height"] - tm) < 1e-12


@pytest.mark.parametrize("v0, duration", [(0.0, 1.0), (1.0, 0.02)])
def test_the_least_height_is_the_least_of_the_steps_ends(v0, duration):
    """The ball in free flight from 6 m above the plane by RK4 steps of 2 ms (exact on
    C's parabola, every step's end a row), dropped for 1 s or thrown up at 1 m/s for
    20 ms: S's least height in the summary is at most the height of every row after the
    start, and lies on the closed form's parabola (dropped: the end's, 6 - g / 2 m, the
    step before within 2 % of it; thrown up: the first step's end, S never as low after,
    every later height within 2 % of it: a least height kept only when 5 % lower, or
    replaced by one up to 5 % higher, would show)."""
    step, H = 0.002, 6.0
    doc = ball(e=0.5, z0=R + H, duration=duration, method="rk4", step=step)
    doc["initial"]["com_velocity"] = [0.0, 0.0, v0]
    res = simulate(doc, progress=False)
    assert res.status == "done" and not res.events
    height = res.model_q[1:, 0] - R              # Z_C - R at each step's end
    t_min, least = res.summary["t_min_height"], res.min_height
    assert least <= height.min() + 1e-15
    assert abs(least - (H + v0 * t_min - 0.5 * G * t_min ** 2)) < 1e-12
    if v0 == 0.0:
        assert t_min == duration and abs(least - (H - 0.5 * G)) < 1e-12
    else:
        assert t_min == res.t[1] and height.max() < 1.02 * least


def test_a_dip_below_the_plane_between_two_samples_is_found():
    """The point swings the ball's centre down and up (z = A cos(W t), nu A W^2 > g): S's
    height h(t) = nu A (1 - cos W t) - delta - g (t - t_m)^2 / 2 dips 1 micrometre below
    the plane around t_m = 2 pi / W for 0.43 ms, in the middle of a quarter of a fixed
    RK4 step of 4 ms (the search's samples, 1 ms apart, all above it).  The impact is at
    the closed form's first root of h (brentq), not at a later crossing or none."""
    from scipy.optimize import brentq
    nu, A, W, step = 0.2 / 1.2, 0.2, 40.0, 0.004
    res, h, tm = swing(1e-6, 20 * step + step / 8, step)
    t_cross = brentq(h, tm - 0.3 / W, tm, xtol=1e-16)
    assert 0.4e-3 < 2 * (tm - t_cross) < step / 8
    assert abs(res.impacts[0, 0] - t_cross) < 1e-9
    # its approach speed: h'(t_cross)
    v = nu * A * W * math.sin(W * t_cross) - G * (t_cross - tm)
    assert abs(res.impacts[0, 2] - v) < 1e-6 * abs(v)


def test_a_spinning_ellipsoids_impact_is_the_closed_forms():
    """An ellipsoid spinning about its principal axis x (kept horizontal; torque-free, so
    A(t) = R_x(w t)) falls: h(t) = Z_C(t) - sqrt(b^2 sin^2 w t + c^2 cos^2 w t), whose
    first root (brentq) is the impact, the gap of a turning body (the ball's impacts are
    polynomial roots, which the dense output holds exactly).  The runtime's is within
    5e-10 s of it at rtol 1e-8 (DOP853)."""
    method, rtol, bound = "dop853", 1e-8, 2e-9
    from scipy.optimize import brentq
    a, b, c, w, z0 = 0.3, 0.5, 0.2, 20.0, 1.0
    doc = scene_dict(body={"mass": 1.0, "inertia": [0.1, 0.12, 0.14], "shape": "ellipsoid",
                           "semi_axes": [a, b, c], "center": [0.0, 0.0, 0.0]},
                     point={"mass": 0.2, "law": ["0", "0", "0"]}, plane={"restitution": 0.5},
                     initial={"com": [0.0, 0.0, z0], "com_velocity": [0.0, 0.0, 0.0],
                              "omega": [w, 0.0, 0.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
                     run={"method": method, "rtol": rtol, "atol": rtol * 1e-2,
                          "duration": 0.5, "outputs": ["pose", "impacts"]})
    doc["body"].pop("radius")

    def h(t):
        return z0 - 0.5 * G * t * t - math.sqrt((b * math.sin(w * t)) ** 2
                                                + (c * math.cos(w * t)) ** 2)
    ts = np.linspace(0.0, 0.5, 20001)
    k = int(np.argmax([h(t) <= 0 for t in ts]))
    t_impact = brentq(h, ts[k - 1], ts[k], xtol=1e-16, rtol=8.9e-16)
    res = simulate(doc, progress=False)
    assert res.status == "done" and len(res.impacts) >= 1
    assert abs(res.impacts[0, 0] - t_impact) < bound


def test_a_start_on_the_plane_pulled_up_grazes_and_lands_where_the_closed_form_does():
    """The ball started on the plane moving down at 1 % of the speed noise while its point
    pulls it up (z = A cos(W t): Z_C'' = -g + nu A W^2 cos(W t) > 0 at t = 0): a graze,
    no impact and no rest, and no cut of the step (the cut after a graze is for S pressed
    onto the plane); S then rises and lands at the first root of its height h(t) = nu A
    (1 - cos W t) - v t - g t^2 / 2, found by SciPy's brentq."""
    from scipy.optimize import brentq
    nu, A, W = 0.2 / 1.2, 0.2, 40.0
    assert nu * A * W ** 2 > G
    v = 0.01 * 1e3 * EPS * math.sqrt(G * R)
    doc = ball(e=0.5, z0=R + nu * A, law=("0", "0", f"{A}*cos({W}*t)"), duration=0.12,
               rtol=RTOL, atol=ATOL, method="dopri5")
    doc["initial"]["com_velocity"] = [0.0, 0.0, -v]
    res = simulate(doc, progress=False)
    assert res.status == "done", res.status
    assert [ev["kind"] for ev in res.events] == ["graze", "impact"]
    assert res.events[0]["t"] == 0.0

    def h(t):
        return nu * A * (1 - math.cos(W * t)) - v * t - 0.5 * G * t * t
    landing = brentq(h, 0.05, 0.12, xtol=1e-15)
    assert abs(res.impacts[0, 0] - landing) < 1e-9, (res.impacts[0, 0], landing)


def test_a_hop_that_ends_inside_the_first_step_is_found_before_s_rises_again():
    """The ball started on the plane (1e-15 m below it, round-off: the search starts
    unarmed) moving up at 1 m/s while its point presses it down (z = -A cos(W t):
    Z_C'' = -g - nu A W^2 cos(W t)), by RK4 with a fixed step of 0.2 s.  S lands at the
    first root of h(t) = v t - g t^2 / 2 - nu A (1 - cos W t) (SciPy's brentq, 0.037 s),
    then would dip 18 mm below the plane and rise above it again at 0.12 s, inside the
    first step: a sample below the plane before S was seen above it retries the step
    shorter, and the landing is the closed form's; taken for S's next rise, the dip
    (and the impact) would be missed."""
    from scipy.optimize import brentq
    nu, A, W, v = 0.2 / 1.2, 0.2, 40.0, 1.0

    def h(t):
        return v * t - 0.5 * G * t * t - nu * A * (1 - math.cos(W * t))
    assert h(0.05) < -1e-3 and h(0.15) > 1e-2             # the dip, and S above again
    doc = ball(e=0.5, z0=R - nu * A - 1e-15, law=("0", "0", f"-{A}*cos({W}*t)"),
               duration=0.3, method="rk4", step=0.2)
    doc["initial"]["com_velocity"] = [0.0, 0.0, v]
    res = simulate(doc, progress=False)
    assert res.status == "done"
    assert res.stats["rejected"] >= 1                      # the first step, retried
    landing = brentq(h, 0.01, 0.06, xtol=1e-15)
    assert abs(res.impacts[0, 0] - landing) < 1e-8, (res.impacts[0, 0], landing)


def test_a_spinning_ellipsoid_that_touches_tangentially_grazes_and_falls_on():
    """An ellipsoid spinning about its principal axis x at 27 rad/s (torque-free, so A(t)
    = R_x(w t)) falls from rest: h(t) = Z_C(t) - sqrt(b^2 sin^2 w t + c^2 cos^2 w t).
    Z_C(0) is set so that h's second local minimum, where the long axis b swings
    through the vertical (h'' = -g - s'' > 0 there: S is pulled up), is exactly 0 at
    t1: a tangential touch.  DOP853 at rtol 1e-8 finds the touch and its refinement
    ends past the lowest point, S moving up: a graze (no impact), within 2e-6 s of t1,
    and the run goes on (a step cut there for a hop of a body pressed down would be
    negative: step_underflow).  The next event is the impact at h's next root
    (SciPy's brentq), at h'(root).  (Whether the search sees a touch of zero depth
    depends on where the steps fall: at rtol 1e-9, 1e-10 or 3e-8 it sees none and the
    first event is that impact; at 1e-8 it is a graze for minima from 1e-11 m above to
    1e-11 m below the plane, and another step-size rule can move it.)"""
    from scipy.optimize import brentq, minimize_scalar
    a, b, c, w = 0.3, 0.33, 0.18, 27.0

    def s(t):
        return math.sqrt((b * math.sin(w * t)) ** 2 + (c * math.cos(w * t)) ** 2)
    tk = 1.5 * math.pi / w
    t1 = minimize_scalar(lambda t: -(0.5 * G * t * t + s(t)), bounds=(tk - 0.4 / w, tk + 0.4 / w),
                         method="bounded", options={"xatol": 1e-12}).x
    z0 = 0.5 * G * t1 * t1 + s(t1)

    def h(t):
        return z0 - 0.5 * G * t * t - s(t)
    assert h(t1) == pytest.approx(0.0, abs=1e-15) and h(0.0) > 0.1
    assert (h(t1 + 1e-4) - 2 * h(t1) + h(t1 - 1e-4)) / 1e-8 > 10 * G     # pulled up
    doc = scene_dict(body={"mass": 1.0, "inertia": [0.1, 0.12, 0.14], "shape": "ellipsoid",
                           "semi_axes": [a, b, c], "center": [0.0, 0.0, 0.0]},
                     point={"mass": 0.2, "law": ["0", "0", "0"]}, plane={"restitution": 0.5},
                     initial={"com": [0.0, 0.0, z0], "com_velocity": [0.0, 0.0, 0.0],
                              "omega": [w, 0.0, 0.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
                     run={"method": "dop853", "rtol": 1e-8, "atol": 1e-10, "duration": 0.3,
                          "outputs": ["pose", "impacts"]})
    doc["body"].pop("radius")
    res = simulate(doc, progress=False)
    assert res.status == "done", res.status
    graze, impact = res.events[:2]
    assert graze["kind"] == "graze" and abs(graze["t"] - t1) < 2e-6
    assert 0.0 <= graze["v_minus"] < 1e-3
    ts = np.linspace(t1 + 1e-3, 0.3, 3001)
    j = int(np.argmax([h(t) <= 0 for t in ts]))
    root = brentq(h, ts[j - 1], ts[j], xtol=1e-15)
    assert impact["kind"] == "impact" and abs(impact["t"] - root) < 1e-8, (impact["t"], root)
    v = -G * root - (b * b - c * c) * w * math.sin(2 * w * root) / (2 * s(root))
    assert abs(impact["v_minus"] - v) < 1e-6 * abs(v)


@pytest.mark.parametrize("rule", ["gap", "speed"])
@pytest.mark.parametrize("band", [0.98, 1.02])
def test_a_start_put_on_the_plane_begins_in_contact_within_round_off_of_it(rule, band):
    """A start put on the plane (the option start_on_plane, which [initial].on_plane sets:
    a scene with com set leaves it off, so the run is the Session's with the option on)
    begins in contact at t0 where S is at rest within the height resolution above the
    plane (h_res = 10 (atol + rtol (|Z_C| + L))) and leaves it slower than the speed
    noise (1e3 eps (|Z_C'| + sqrt(g L)) for the ball, whose rate is 0); each threshold
    from that arithmetic, the start at 0.98 and 1.02 of it.  Inside, the contact at t0
    and no impact; outside, a flight first: from 1.02 h_res the ball falls and lands at
    the closed form's sqrt(2 h / g), and leaving at 1.02 of the noise it flies and lands
    (an impact after t0, within the height resolution's fall)."""
    from derive.runtime.build import library
    from derive.runtime.driver import prepare
    from derive.runtime.session import Session
    doc = ball(e=0.5, z0=R, duration=0.01, rtol=RTOL, atol=ATOL, method="dopri5")
    prep = prepare(doc)
    assert prep.kind == "translational" and list(prep.start.q0) == [R, 0.0]
    opt = prep.options.copy()
    assert opt[abi.OPT["start_on_plane"]] == 0.0            # com given: not on the plane
    opt[abi.OPT["start_on_plane"]] = 1.0
    L = opt[abi.OPT["length_scale"]]
    if rule == "gap":
        # h = band h_res(Z_C = R + h), solved for h (the rtol branch of the max)
        h = band * 10 * (ATOL + RTOL * (R + L)) / (1 - band * 10 * RTOL)
        assert ATOL + RTOL * (R + h + L) > 64 * EPS * (R + h + L)
        q0 = [R + h, 0.0]
    else:
        # v = band x 1e3 eps (v + sqrt(g L)), solved for v; S leaving the plane at v
        h = 0.0
        v = band * 1e3 * EPS * math.sqrt(G * L) / (1 - band * 1e3 * EPS)
        q0 = [R, v]
    session = Session(library(prep.kind))
    session.set_law(prep.scene.runtime_law)
    raw = session.run(0.0, 0.01, np.array(q0), opt, prep.parameters)
    assert raw.status == "done"
    kinds = abi.names(abi.EVENT_KINDS)
    events = [(row[0], kinds[int(row[1])]) for row in raw.events]
    if band < 1:
        assert events == [(0.0, "contact")] and raw.stats["impacts"] == 0
        # the start's row, then S put on the plane and resting there
        assert np.max(np.abs(raw.q[1:, 0] - R)) < 1e-12 and raw.t[1] == 0.0
    else:
        (t1, first), (t2, second) = events
        assert (first, second) == ("impact", "contact") and t1 == t2 > 0.0
        if rule == "gap":
            assert abs(t1 - math.sqrt(2 * h / G)) < 1e-6 * t1
        else:
            h_res = 10 * (ATOL + RTOL * (R + L))
            assert G * t1 * t1 / 2 < h_res

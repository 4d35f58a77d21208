"""Issue 14: planning the point's law (derive plan).

Every plan is checked against something computed another way:

* the geometric phase of P on a circle in the body plane z = 0 with K = 0: the angle
  given by E4.2 with zero constant (``derive.reduced.planar``), in closed form for a
  circle about O and by quadrature in the angle otherwise;
* an independent re-integration of the written ``scene.toml`` and ``law.csv``: the
  two-body Newton-Euler formulation of ``tests/test_newton_euler.py`` (forces between
  body and point, impacts with the point's impulse as an unknown) integrated by SciPy,
  with the table read here by SciPy's ``CubicSpline``;
* the hop's vertical multipliers against the closed form of the ball on a vibrating
  table (reference [5], ``derive/stability/bouncing.py``);
* the law's evaluation against SciPy's ``BSpline`` and the compiled law.c against both.
"""
from __future__ import annotations

import copy
import json
import math
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import quad, solve_ivp
from scipy.interpolate import BSpline, CubicSpline

from cases import Case
from test_newton_euler import newton_euler_flight, newton_euler_impact

import derive
from derive import notation as nt
from derive.planner.core import plan as make_plan
from derive.planner.task import load_task, parse_task
from derive.reduced import planar
from derive.scene import SceneError

EXAMPLES = Path(derive.__file__).parent / "planner" / "examples"
CC, CXX = shutil.which("cc"), shutil.which("g++")
STRICT = ["-Wall", "-Wextra", "-Wpedantic", "-Werror"]


def rotation_angle(A_target, A) -> float:
    R = A_target.T @ A
    s = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return math.atan2(s, 0.5 * (np.trace(R) - 1))


def skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


# ---- the written files, read independently ---------------------------------------------
class Written:
    """A plan written to a folder, read back with tomllib, numpy and SciPy only."""

    def __init__(self, result, folder: Path):
        result.write(folder)
        self.folder = folder
        self.result = result
        self.scene = tomllib.loads((folder / "scene.toml").read_text())
        self.summary = json.loads((folder / "plan.json").read_text())
        data = np.genfromtxt(folder / self.scene["point"]["table"], delimiter=",",
                             names=True)
        self.t = data["t"]
        xyz = np.column_stack([data["x"], data["y"], data["z"]])
        ends = self.scene["point"]["ends"]
        bc = {"periodic": "periodic", "free": "not-a-knot",
              "rest": ((1, np.zeros(3)), (1, np.zeros(3)))}[ends]
        self.ends = ends
        self.spline = CubicSpline(self.t, xyz, axis=0, bc_type=bc)

    def law(self, t):
        if self.ends == "periodic":
            t = self.t[0] + np.mod(t - self.t[0], self.t[-1] - self.t[0])
        return (self.spline(t), self.spline(t, 1), self.spline(t, 2))


def newton_euler_run(w: Written, t_end: float, max_impacts: int = 10):
    """Integrate the written scene with the Newton-Euler formulation: state (R_O, V_O,
    omega, A); impacts where the sphere's lowest point reaches Z = 0.  Returns the final
    (t, y) and a list of impacts (t, state before, state after, case before)."""
    sc = w.scene
    body, point = sc["body"], sc["point"]
    M, m, J = body["mass"], point["mass"], np.array(body["inertia"])
    g = sc["run"]["g"]
    e = sc.get("plane", {}).get("restitution", 1.0)
    frac = m / (m + M)
    ini = sc["initial"]
    t0 = ini["time"]
    A0 = np.array(ini["matrix"])
    omega0 = np.array(ini["omega"])
    r, v, _ = w.law(t0)
    R_O = np.array(ini["com"]) - frac * A0 @ r
    V_O = np.array(ini["com_velocity"]) - frac * A0 @ (v + np.cross(omega0, r))
    y = np.r_[R_O, V_O, omega0, A0.ravel()]
    sphere = "radius" in body
    center = np.array(body.get("center", [0.0, 0.0, 0.0]))

    def case(t, y):
        r, v, a = w.law(t)
        A = y[9:18].reshape(3, 3)
        n = A[2]
        s = center - body["radius"] * n / np.linalg.norm(n) if sphere else np.zeros(3)
        return Case(M=M, m=m, J=J, g=g, e=e, A=A, omega=y[6:9], r=r, v=v, acc=a, s=s,
                    R_C=y[0:3] + frac * A @ r,
                    V_C=y[3:6] + frac * A @ (v + np.cross(y[6:9], r)))

    def rhs(t, y):
        c = case(t, y)
        a_O, omega_dot = newton_euler_flight(c)
        return np.r_[y[3:6], a_O, omega_dot, (c.A @ skew(c.omega)).ravel()]

    def height(t, y):
        c = case(t, y)
        return (y[0:3] + c.A @ c.s)[2]
    height.terminal, height.direction = True, -1
    # the spline's acceleration has a kink at every knot: integrate knot to knot, where
    # the right-hand side is smooth (DOP853 at 1e-12 otherwise crawls through each kink)
    span = w.t[-1] - w.t[0]
    laps = int(np.ceil((t_end - w.t[0]) / span)) + 1 if w.ends == "periodic" else 1
    stops = np.unique(np.concatenate([w.t + k * span for k in range(laps)] + [[t_end]]))
    impacts, t = [], t0
    while t < t_end and len(impacts) < max_impacts:
        stop = min(stops[stops > t + 1e-12][0], t_end)
        sol = solve_ivp(rhs, (t, stop), y, method="DOP853", rtol=1e-12, atol=1e-14,
                        events=height if sphere and "plane" in sc else None)
        if sol.status == 1:
            t = float(sol.t_events[0][0])
            before = sol.y_events[0][0]
            c = case(t, before)
            V_O_plus, omega_plus, impulse = newton_euler_impact(c)
            y = np.r_[before[0:3], V_O_plus, omega_plus, before[9:18]]
            impacts.append({"t": t, "before": before, "after": y.copy(), "case": c,
                            "I": impulse})
            y = solve_ivp(rhs, (t, t + 1e-9), y, method="DOP853", rtol=1e-12,
                          atol=1e-14).y[:, -1]
            t += 1e-9
        else:
            t, y = stop, sol.y[:, -1]
    return t, y, impacts, case


# ---- plans shared by the tests -------------------------------------------------------
@pytest.fixture(scope="module")
def reorient(tmp_path_factory):
    return Written(make_plan(EXAMPLES / "reorient.toml"), tmp_path_factory.mktemp("reorient"))


@pytest.fixture(scope="module")
def hop(tmp_path_factory):
    return Written(make_plan(EXAMPLES / "hop.toml"), tmp_path_factory.mktemp("hop"))


CIRCLE_TASK = """
name = "circle"
[body]
mass = 1.0
inertia = [0.010, 0.012, 0.015]
shape = "none"
[point]
mass = 0.5
[plan]
goal = "reorient"
horizon = 1.5
max_acceleration = 30.0
"""


def _rz(angle):
    c, s = math.cos(angle), math.sin(angle)
    return [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]


# ---- closed forms ----------------------------------------------------------------------
@pytest.mark.parametrize("center", [(0.0, 0.0), (0.03, 0.02)])
def test_circle_geometric_phase(center, tmp_path, capfd):
    """P on a circle in the body plane z = 0, K = 0, asked to turn the body by 30 degrees
    about z.  E4.2 with zero constant gives omega_z = -mu (x y' - y x')/(J_z + mu r^2):
    per unit of the circle's angle theta it depends on theta only, so the body's turn is a
    function of the arc (a geometric phase), whatever the timing.  About O it is
    -mu R^2/(J_z + mu R^2) per radian; off O, the quadrature of E4.2 in theta.  The
    plan is asked through the public API (derive.plan), which writes nothing to stdout or
    stderr (captured at the file descriptors, so IPOPT's own output would show)."""
    target = math.radians(30.0)
    R, a0 = 0.1, 0.3
    doc = tomllib.loads(CIRCLE_TASK)
    doc["plan"]["target_matrix"] = _rz(target)
    doc["plan"]["circle"] = {"center": list(center), "radius": R, "start_angle": a0}
    capfd.readouterr()
    result = derive.plan(doc)
    captured = capfd.readouterr()
    assert captured.out == "" and captured.err == ""
    assert result.ok, result.message
    w = Written(result, tmp_path)
    law = result.law
    theta1 = float(law.spline_values(law.T)[0][0, 0])      # the planned end of the arc
    M, m, Jz = 1.0, 0.5, 0.015
    mu = M * m / (M + m)
    if center == (0.0, 0.0):
        closed = -mu * R * R / (Jz + mu * R * R) * (theta1 - a0)
    else:
        rate = sp.lambdify(sp.Symbol("th"), planar().omega_z.xreplace({
            planar().kappa: 0, nt.mu: mu, nt.J_z: Jz,
            nt.x: center[0] + R * sp.cos(sp.Symbol("th")),
            nt.y: center[1] + R * sp.sin(sp.Symbol("th")),
            nt.xd: -R * sp.sin(sp.Symbol("th")), nt.yd: R * sp.cos(sp.Symbol("th"))}))
        closed = quad(rate, a0, theta1, epsabs=1e-14, epsrel=1e-14)[0]
    # the closed form of the planned arc is the target...
    assert abs(closed - target) < 1e-8, (closed, target)
    # ...and the re-simulated written scene turns the body by it
    t, y, _, _ = newton_euler_run(w, law.T)
    A = y[9:18].reshape(3, 3)
    turned = math.atan2(A[1, 0], A[0, 0])
    print(f"circle about {center}: theta {a0} -> {theta1:.9f}, closed form "
          f"{closed:.12f}, Newton-Euler {turned:.12f}, target {target:.12f}")
    assert abs(turned - closed) < 1e-8
    achieved = w.summary["achieved"]["scipy"]["attitude_error_rad"]
    assert achieved < 1e-8
    if CC and CXX:      # the circle's C law (the angle's table, then the circle) plays it back
        ts = np.r_[np.linspace(0, law.T, 25), 1.2 * law.T]
        rows = play_law(w.folder, tmp_path, ts)
        assert list(rows[:, 0]) == [0] * 25 + [1]   # outside the table: flagged
        assert np.max(np.abs(rows[:-1, 1:] - law.u(ts[:-1]).T)) < 1e-12
        r, v, acc = w.law(ts[:-1])
        assert np.max(np.abs(rows[:-1, 1:4] - r)) < 1e-10   # and the table's spline


def test_reorient_planar_matches_e42_and_newton_euler(reorient):
    """The example (90 degrees about z, K = 0, P in a ball): the runtime adapter's error,
    the E4.2 integral along the written law, and the Newton-Euler re-integration."""
    w = reorient
    s = w.summary
    assert s["status"] == "solved"
    assert s["achieved"]["scipy"]["attitude_error_rad"] < 1e-8
    # E4.2 with zero constant along the tabulated law (z = 0 in the plan)
    T = w.t[-1]
    xs, xd, _ = w.law(w.t)
    assert np.max(np.abs(xs[:, 2])) < 1e-12
    mu, Jz = 1.0 * 0.5 / 1.5, 0.015
    nodes, weights = np.polynomial.legendre.leggauss(6)
    total = 0.0
    for a, b in zip(w.t[:-1], w.t[1:]):
        tt = 0.5 * (a + b) + 0.5 * (b - a) * nodes
        (r, v, _) = w.law(tt)
        wz = -mu * (r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]) / (Jz + mu * (r[:, 0] ** 2
                                                                        + r[:, 1] ** 2))
        total += 0.5 * (b - a) * weights @ wz
    assert abs(total - math.pi / 2) < 1e-8, total
    t, y, _, _ = newton_euler_run(w, T)
    target = np.array(load_task(EXAMPLES / "reorient.toml").target)
    err = rotation_angle(target, y[9:18].reshape(3, 3))
    print(f"reorient: E4.2 integral {total:.12f} (pi/2 = {math.pi / 2:.12f}), "
          f"Newton-Euler error {err:.2e} rad, SciPy on the derived functions "
          f"{s['achieved']['scipy']['attitude_error_rad']:.2e}")
    assert err < 1e-8


def test_reorient_3d(tmp_path):
    """60 degrees about (1, 1, 1)/sqrt(3), K = 0, an unsymmetric body."""
    task = load_task(EXAMPLES / "reorient3d.toml")
    R = task.target
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    axis /= np.linalg.norm(axis)
    assert np.max(np.abs(axis)) < 0.99          # not a principal axis
    w = Written(make_plan(task), tmp_path)
    assert w.summary["achieved"]["scipy"]["attitude_error_rad"] < 1e-8
    _, y, _, _ = newton_euler_run(w, w.t[-1])
    err = rotation_angle(R, y[9:18].reshape(3, 3))
    print(f"3-D reorientation: Newton-Euler error {err:.2e} rad")
    assert err < 1e-8
    # the body ends at rest (K = 0 and P at rest)
    assert np.max(np.abs(y[6:9])) < 1e-8


@pytest.mark.parametrize("name", ["land.toml", "land_d0.toml"])
def test_land(name, tmp_path):
    task = load_task(EXAMPLES / name)
    w = Written(make_plan(task), tmp_path)
    s = w.summary
    assert s["status"] == "solved"
    T = s["law"]["duration"]
    t, y, impacts, case = newton_euler_run(w, w.scene["run"]["duration"], max_impacts=1)
    assert impacts, "no touchdown in the Newton-Euler run"
    first = impacts[0]
    assert abs(first["t"] - T) < 1e-9
    # past touchdown the table holds P where the law ends (it is at rest there), not the
    # last piece's cubic carried on (a new-user trial found |x''| up to 17.8 m/s^2 there)
    later = w.t[w.t > T]
    r, v, a = w.law(later)
    assert len(later) > 5 and np.max(np.abs(r - w.law(np.array([T]))[0])) < 1e-12
    assert np.max(np.abs(v)) < 1e-9 and np.max(np.abs(a)) < 1e-6
    A = first["before"][9:18].reshape(3, 3)
    if task.at_touchdown == "attitude":
        err = rotation_angle(task.target, A)
        print(f"{name}: touchdown at {first['t']:.12f} (planned {T:.12f}), attitude error "
              f"{err:.2e} rad (SciPy/derived {s['achieved']['scipy']['attitude_error_rad']:.2e})")
        assert err < 1e-8
        assert s["achieved"]["scipy"]["attitude_error_rad"] < 1e-8
    else:
        jump = np.linalg.norm(first["after"][6:9] - first["before"][6:9])
        c = first["case"]
        CS = c.s - (c.m / (c.m + c.M)) * c.r
        d = np.cross(CS, c.A[2])
        print(f"{name}: |d| = {np.linalg.norm(d):.2e}, Newton-Euler |omega+ - omega-| = "
              f"{jump:.2e}, impulse {first['I']:.4f}")
        assert np.linalg.norm(d) < 1e-10
        assert jump < 1e-8 and first["I"] > 0.1
        assert s["achieved"]["scipy"]["omega_jump"] < 1e-8


def test_hop(hop):
    """The planned periodic hop: the orbit re-simulated (SciPy on the derived functions and
    Newton-Euler), its multipliers' checks, and the vertical pair against reference [5]."""
    w = hop
    s = w.summary
    task = load_task(EXAMPLES / "hop.toml")
    assert s["status"] == "solved"
    T = s["law"]["duration"]
    ach = s["achieved"]["scipy"]
    assert ach["impacts"] >= 3 and ach["apex_error"] < 1e-8 and ach["max_state_error"] < 1e-8
    # Newton-Euler: two periods from mid-flight, apex of C after every impact
    t0 = w.scene["initial"]["time"]
    _, _, impacts, _ = newton_euler_run(w, t0 + 2 * T, max_impacts=3)
    assert len(impacts) == 2
    g = w.scene["run"]["g"]
    for k, imp in enumerate(impacts):
        c = imp["case"]
        after = imp["after"]
        frac = c.m / (c.m + c.M)
        Vz = (after[3:6] + frac * c.A @ (c.v + np.cross(after[6:9], c.r)))[2]
        Zc = (after[0:3] + frac * c.A @ c.r)[2]
        apex = Zc + Vz ** 2 / (2 * g)
        print(f"hop: impact {k} at t = {imp['t']:.12f} (k T = {(k + 1) * T:.12f}), apex "
              f"{apex:.12f} (asked {task.apex_height})")
        assert abs(imp["t"] - (k + 1) * T) < 1e-9
        assert abs(apex - task.apex_height) < 1e-8
    st = s["stability"]
    assert all(c["ok"] for c in st["checks"].values()), st["checks"]
    assert st["stable"] and not st["verdict"].startswith("unstable")
    # the vertical pair: rho^2 - tr rho + e^2 with tr = 1 + e^2 + (1 + e)^2 nu z''/g at the
    # impact (the table's closed form; here P moves on the body axis and the axis stays up)
    e, nu = task.scene.e, task.scene.m / (task.scene.m + task.scene.M)
    _, _, a = w.law(np.array([0.0]))
    assert np.max(np.abs(w.law(w.t)[0][:, 0:2])) < 1e-12
    tr = 1 + e * e + (1 + e) ** 2 * nu * a[0, 2] / g
    table = np.roots([1.0, -tr, e * e])
    rho = np.array([complex(*p) for p in st["multipliers"]])
    for r in table:
        assert np.min(np.abs(rho - r)) < 1e-6, (r, rho)


def test_hop_effort_optimum_is_unstable_and_reported(hop):
    """The effort-optimal hop of the example is unstable (its tilt multipliers leave the
    unit circle); the plan says so and keeps the orbit found with the stability
    conditions, at a higher effort."""
    first, second = hop.summary["stability_attempts"]
    assert first["verdict"].startswith("unstable") and first["max_modulus"] > 1.5
    assert not second["verdict"].startswith("unstable")
    assert second["effort"] > first["effort"]


def test_hop_require_stable_refuses_an_unstable_orbit():
    """With the region above O, C cannot be below the sphere's centre at the impact (the
    tilt condition), so no stable orbit is found and require_stable makes the task
    infeasible, naming that condition."""
    doc = tomllib.loads((EXAMPLES / "hop.toml").read_text())
    doc["plan"]["region"] = {"center": [0.0, 0.0, 0.06], "radius": 0.04}
    doc["plan"]["require_stable"] = True
    result = make_plan(doc)
    assert result.status == "infeasible"
    assert "require_stable" in result.message and "stability (tilt)" in result.message
    first = result.summary.stability_attempts[0]
    assert first["verdict"].startswith("unstable")


# ---- the law -----------------------------------------------------------------------------
def test_law_against_scipy_bspline(reorient):
    law = reorient.result.law
    n, T = law.spline.n, law.T
    h = T / n
    knots = np.arange(-3, n + 4) * h
    t = np.linspace(0, T, 2001)
    for d in range(3):
        peer = BSpline(knots, law.ctrl, 3)(t, nu=d) if d else BSpline(knots, law.ctrl, 3)(t)
        ours = law.spline_values(t)[d].T
        assert np.max(np.abs(ours - peer)) < 1e-12 * max(1.0, np.max(np.abs(peer)))
    # the table is read back by the runtime's spline to within 1e-10
    mid = 0.5 * (reorient.t[1:] + reorient.t[:-1])
    assert np.max(np.abs(reorient.spline(mid) - law.u(mid)[0:3].T)) < 1e-10


PLAYER = """#include "law.h"
#include <cstdio>
#include <cstdlib>
int main(int argc, char **argv) {
  for (int i = 1; i < argc; ++i) {
    double u[9];
    double t = std::atof(argv[i]);
    int out = carrier_law_eval(t, u);
    std::printf("%d", out);
    for (int k = 0; k < 9; ++k) std::printf(" %.17g", u[k]);
    std::printf("\\n");
  }
  return 0;
}
"""


def play_law(folder: Path, tmp: Path, ts) -> np.ndarray:
    """Compile law.c (C99, strict) and a C++ player including law.h (strict); check that
    the object has no writable data and calls no allocator; return its rows (flag, u)."""
    (tmp / "main.cpp").write_text(PLAYER)
    obj = tmp / "law.o"
    subprocess.run([CC, "-std=c99", *STRICT, "-O2", "-c", str(folder / "law.c"), "-o",
                    str(obj)], check=True, capture_output=True, text=True)
    exe = tmp / "play"
    subprocess.run([CXX, "-std=c++11", *STRICT, "-I", str(folder), str(tmp / "main.cpp"),
                    str(obj), "-o", str(exe), "-lm"], check=True, capture_output=True,
                   text=True)
    nm = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
    kinds = {line.split()[-2] for line in nm.splitlines() if len(line.split()) >= 2}
    assert not kinds & set("BbDdGgSs"), nm          # no writable static data
    assert "malloc" not in nm and "free" not in nm.split()
    out = subprocess.run([str(exe), *[repr(float(t)) for t in ts]], capture_output=True,
                         text=True, check=True).stdout.splitlines()
    return np.array([[float(v) for v in line.split()] for line in out if line.strip()])


@pytest.mark.skipif(CC is None or CXX is None, reason="no C/C++ compiler")
def test_law_c_compiles_strict_and_matches(hop, tmp_path):
    T = hop.result.law.T
    ts = np.r_[np.linspace(0, T, 37), 2.5 * T, -0.3 * T]
    rows = play_law(hop.folder, tmp_path, ts)
    assert np.all(rows[:, 0] == 0)                 # periodic: always inside
    r, v, a = hop.law(ts)
    peer = np.column_stack([r, v, a])
    scale = np.maximum(1.0, np.max(np.abs(peer), axis=0))
    assert np.max(np.abs(rows[:, 1:] - peer) / scale) < 1e-9
    ours = hop.result.law.u(ts).T
    assert np.max(np.abs(rows[:, 1:] - ours) / scale) < 1e-12
    nan = play_law(hop.folder, tmp_path, [float("nan")])
    assert nan[0, 0] == 1 and np.all(np.isnan(nan[0, 1:]))


@pytest.mark.skipif(CC is None or CXX is None, reason="no C/C++ compiler")
def test_a_repeating_law_repeats_in_law_c(reorient, tmp_path):
    """reorient's law is at rest at both ends and back at its start, so scene.toml says
    ends = "periodic": law.h says so too and law.c wraps t into the period (it had said
    'does not repeat' and extended the end pieces)."""
    assert reorient.scene["point"]["ends"] == "periodic"
    assert "#define CARRIER_LAW_PERIODIC 1" in (reorient.folder / "law.h").read_text()
    T = reorient.result.law.T
    ts = np.array([0.1, 0.5, 0.9]) * T
    rows = play_law(reorient.folder, tmp_path, np.r_[ts, ts + T, ts - 3 * T])
    assert np.all(rows[:, 0] == 0)
    assert np.max(np.abs(rows[3:6] - rows[0:3])) < 1e-12
    assert np.max(np.abs(rows[6:9] - rows[0:3])) < 1e-12


@pytest.mark.parametrize("name", ["reorient.toml", "hop.toml", "land.toml"])
def test_structured_derivatives_match_casadi_ad(name):
    """IPOPT gets the Jacobian and the Hessian of the Lagrangian assembled from one RK4
    interval's derivatives; CasADi's AD of the whole expanded NLP must give the same."""
    import casadi as ca
    from derive.planner.goals import goal_of
    from derive.planner.transcribe import Transcription
    doc = tomllib.loads((EXAMPLES / name).read_text())
    doc["plan"]["intervals"] = 6
    task = parse_task(doc)
    tr = Transcription(task, goal_of(task))
    rng = np.random.default_rng(3)
    x = tr.goal.guess(tr) * (1 + 1e-2 * rng.normal(size=tr.w.shape[0]))
    # the defect correction and 1/max_acceleration^2 (the limit is a parameter)
    p = np.r_[1e-3 * rng.normal(size=tr.delta.numel()), 1 / 7.0 ** 2]
    lam = rng.normal(size=tr.g.shape[0])
    w, ps = ca.SX.sym("w", tr.w.shape[0]), ca.SX.sym("p", tr.n_p)
    J, g = ca.Function("nlp", [tr.w, tr.params], [tr.J, tr.g]).expand()(w, ps)
    jac = ca.Function("ad_jac", [w, ps], [ca.jacobian(g, w)])(x, p)
    hess = ca.Function("ad_hess", [w, ps], [ca.hessian(0.7 * J + ca.dot(lam, g), w)[0]])(x, p)
    g_ours, jac_ours = tr.jacobian_function()(x, p)
    hess_ours = tr.hessian_function()(x, p, 0.7, lam)
    jac, jac_ours = np.array(jac.full()), np.array(jac_ours.full())
    hess, hess_ours = np.triu(np.array(hess.full())), np.array(hess_ours.full())
    assert np.max(np.abs(jac_ours - jac)) <= 1e-12 * max(1.0, np.max(np.abs(jac)))
    assert np.max(np.abs(hess_ours - hess)) <= 1e-12 * max(1.0, np.max(np.abs(hess)))


# ---- errors and the command line ---------------------------------------------------------
BAD = [
    (("plan", "goal"), "spin", "[plan].goal"),
    (("plan", "max_acceleration"), -1.0, "[plan].max_acceleration"),
    (("plan", "target_matrix"), [[1, 0, 0], [0, 1, 0], [0, 0, -1]], "[plan].target_matrix"),
    (("plan", "region"), {"center": [0, 0, 0], "radius": 0.1, "shape": "cube"},
     "[plan].region.shape"),
    (("plan", "region"), {"center": [0, 0, 0], "radius": -0.1}, "[plan].region.radius"),
    (("plan", "intervals"), 2, "[plan].intervals"),
    (("body", "mass"), 0.0, "[body].mass"),
    (("point", "law"), ["t", "0", "0"], "[point].law"),
    (("plan", "horizon"), float("nan"), "[plan].horizon"),
]


@pytest.mark.parametrize("path, value, where", BAD)
def test_bad_tasks_name_the_field(path, value, where):
    doc = tomllib.loads((EXAMPLES / "reorient.toml").read_text())
    table, key = path
    doc[table][key] = copy.deepcopy(value)
    with pytest.raises(SceneError) as info:
        parse_task(doc)
    assert info.value.where == where, str(info.value)


def test_cli_bad_task_exit_2_nothing_written(tmp_path):
    task = tmp_path / "bad.toml"
    text = (EXAMPLES / "reorient.toml").read_text().replace("max_acceleration = 20.0",
                                                            "max_acceleration = -3.0")
    task.write_text(text)
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "derive", "plan", str(task), "-o", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "derive plan: [plan].max_acceleration: must be > 0 (got -3.0)"]
    assert "Traceback" not in proc.stderr and not out.exists()


def test_cli_writes_outputs_and_progress(reorient, tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "derive", "plan",
                           str(EXAMPLES / "reorient.toml"), "-o", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    names = {p.name for p in out.iterdir()}
    assert {"law.csv", "scene.toml", "plan.json", "law.c", "law.h", "law.png",
            "motion.png"} <= names
    s = json.loads((out / "plan.json").read_text())
    # a progress line per IPOPT iteration (numbered from 0, the starting point; IPOPT
    # reports an occasional extra one, e.g. when its line search restarts)
    last = {}
    for ln in proc.stderr.splitlines():
        if ln.startswith("  plan reorient  round"):
            words = ln.split()
            last[int(words[3])] = int(words[5])
    solves = {r["round"]: r["iterations"] for r in s["solver"]["solves"]}
    assert set(last) == set(solves)
    for r, its in solves.items():
        assert its <= last[r] <= its + 2 + its // 10, (r, its, last[r])
    # the same plan as the Python API's, to the solver's accuracy
    assert abs(s["law"]["effort"] - reorient.summary["law"]["effort"]) < 1e-6


def test_infeasible_names_the_blocking_limit(reorient, tmp_path, monkeypatch, capsys):
    """With max_acceleration far below what the reorientation needs, the plan is
    infeasible and names max_acceleration; the acceleration it reports as needed is the
    one of the example's plan, where the limit is inactive (solved independently)."""
    doc = tomllib.loads((EXAMPLES / "reorient.toml").read_text())
    doc["plan"]["max_acceleration"] = 0.2
    doc["plan"]["max_iterations"] = 150
    result = make_plan(doc)
    assert result.status == "infeasible"
    assert "max_acceleration" in result.message
    need = result.summary.blocking["needed"]
    assert result.summary.blocking["limit"] == "max_acceleration"
    assert abs(need - reorient.summary["law"]["max_acceleration"]) < 1e-4 * need
    # the CLI says it once: stdout reports the run, stderr the diagnosis
    import argparse

    from derive.planner import cli, core
    task = tmp_path / "task.toml"
    task.write_text((EXAMPLES / "reorient.toml").read_text())
    monkeypatch.setattr(core, "plan", lambda task, progress: result)
    args = argparse.Namespace(task=str(task), output=str(tmp_path / "o"), quiet=True)
    assert cli.run(args) == 1
    out, err = capsys.readouterr()
    assert (out + err).count(result.message) == 1
    assert err.strip() == f"derive plan: {result.message}" and "diagnosis:" in out


# ---- the diagnosis of an infeasible task, and loose bounds --------------------------------
def ellipsoid_landing(radius: float, max_acceleration: float) -> dict:
    """The landing of a new-user trial: land.toml with an ellipsoid (semi-axes 0.15, 0.15,
    0.10), M = 2, m = 0.5, P in a ball of the given radius."""
    doc = tomllib.loads((EXAMPLES / "land.toml").read_text())
    doc["body"].update(mass=2.0, shape="ellipsoid", semi_axes=[0.15, 0.15, 0.10])
    del doc["body"]["radius"]
    doc["point"]["mass"] = 0.5
    doc["plan"]["region"]["radius"] = radius
    doc["plan"]["max_acceleration"] = max_acceleration
    return doc


def _solves_with(doc: dict, **plan) -> dict:
    """Plan the task with [plan] changed: the plan's summary (it must be solved)."""
    doc = copy.deepcopy(doc)
    for key, value in plan.items():
        if key == "radius":
            doc["plan"]["region"]["radius"] = value
        else:
            doc["plan"][key] = value
    result = make_plan(doc, runtime=False)
    assert result.ok, result.message
    return result.summary.to_dict()


def _finding(summary, limit: str) -> dict:
    return next(f for f in summary.blocking["findings"] if f["limit"] == limit)


def test_diagnosis_names_each_limit_that_blocks_with_what_it_needs():
    """P in a ball of 0.085 m with |OP''| <= 20: both limits block (the trial's first
    version named the first it lifted and stopped).  What each needs is checked by
    solving the task with that limit set 1 % above it: it solves, and its plan uses it."""
    doc = ellipsoid_landing(0.085, 20.0)
    result = make_plan(doc, runtime=False)
    assert result.status == "infeasible"
    b = result.summary.blocking
    assert b["limit"] == "region"          # the larger excess (0.19 against 0.085) first
    acc, region = _finding(result.summary, "max_acceleration"), _finding(result.summary,
                                                                           "region")
    assert acc["verdict"] == region["verdict"] == "blocks"
    assert result.message.startswith(f"infeasible: region blocks it: the plan needs a "
                                     f"region of radius {region['needed']:.4g} m")
    assert (f"max_acceleration blocks it too: the plan needs |OP''| up to "
            f"{acc['needed']:.4g} m/s^2 (limit 20)") in result.message
    s = _solves_with(doc, max_acceleration=1.01 * acc["needed"])
    assert abs(s["law"]["max_acceleration"] - acc["needed"]) < 1e-3 * acc["needed"]
    s = _solves_with(doc, radius=1.01 * region["needed"])
    assert s["law"]["max_distance_from_region_center"] <= region["needed"]


def test_diagnosis_of_the_trial_task_names_the_region():
    """The trial's task (a ball of 0.06 m) with max_acceleration = 1e6: the first version
    ended "no single limit (max_acceleration, region, horizon) unblocks it: the goal
    itself is out of reach" (its objective, scaled by 1/max_acceleration^2, was 1e-12 of
    the constraints, and the lifted solves started cold).  The region blocks it, and the
    radius it reports is enough."""
    doc = ellipsoid_landing(0.06, 1e6)
    result = make_plan(doc, runtime=False)
    assert result.status == "infeasible"
    b = result.summary.blocking
    assert b["limit"] == "region" and "out of reach" not in result.message
    assert result.message.startswith(f"infeasible: region blocks it: the plan needs a "
                                     f"region of radius {b['needed']:.4g} m (radius 0.06 m)")
    _solves_with(doc, radius=1.01 * b["needed"])


def test_a_limit_left_unexamined_says_what_is_known_of_it():
    """The trial's task at max_acceleration = 20: the region blocks it, and the budget may
    run out before max_acceleration is examined.  A second trial read "max_acceleration
    not examined" as a verdict on the acceleration, though the region's own plan kept
    |OP''| <= 20; the finding now says so, and that raising the region alone suffices,
    which is checked by planning the task with the region 1 % above its need."""
    doc = ellipsoid_landing(0.06, 20.0)
    result = make_plan(doc, runtime=False)
    assert result.status == "infeasible" and result.summary.blocking["limit"] == "region"
    region = _finding(result.summary, "region")
    acc = _finding(result.summary, "max_acceleration")
    assert region["plan_needs"]["max_acceleration"] <= 20.0 * (1 + 1e-6)
    if acc["verdict"] == "not examined":
        assert acc["text"].startswith("raising region alone unblocks it: that plan keeps "
                                      "max_acceleration (|OP''| up to 20 m/s^2, limit 20)")
    assert acc["text"] in result.message and result.message.count("max_acceleration") >= 1
    s = _solves_with(doc, radius=1.01 * region["needed"])
    assert s["law"]["max_acceleration"] <= 20.0 * (1 + 1e-6)


def test_diagnosis_names_the_horizon_with_the_free_fall_time():
    """A sphere dropped without spin, asked to land as it is with P at rest at O, within
    half the time it takes: the horizon blocks it, and the time the plan takes is the
    free fall of its lowest point, sqrt(2 (Z - r)/g) (C stays at O, the law being at
    rest)."""
    doc = tomllib.loads((EXAMPLES / "land.toml").read_text())
    doc["initial"] = {"com": [0.0, 0.0, 1.5], "com_velocity": [0.0, 0.0, 0.0],
                      "omega": [0.0, 0.0, 0.0]}
    free_fall = math.sqrt(2 * (1.5 - doc["body"]["radius"]) / 9.81)
    doc["plan"]["horizon"] = 0.5 * free_fall
    result = make_plan(doc, runtime=False)
    assert result.status == "infeasible"
    b = result.summary.blocking
    assert b["limit"] == "horizon", result.message
    assert abs(b["needed"] - free_fall) < 1e-6 * free_fall, (b["needed"], free_fall)
    assert result.message.startswith(f"infeasible: horizon blocks it: the plan takes "
                                     f"{free_fall:.4g} s")


def test_a_looser_acceleration_bound_is_never_worse():
    """The trial found a looser bound ending at a worse plan (effort 216 at 1e6 against
    179 at 60) or at none.  On this landing (a ball of 0.1 m) the first version solved the
    task at 60 and failed at 1e6 after 400 iterations; the bound is now approached from a
    working bound: the plan at 1e6 is solved, with no more effort than at 60."""
    doc = ellipsoid_landing(0.1, 60.0)
    tight = _solves_with(doc)
    loose = _solves_with(doc, max_acceleration=1e6)
    assert loose["law"]["effort"] <= tight["law"]["effort"] * (1 + 1e-9)
    assert any("continuation" in r.get("stage", "") for r in loose["solver"]["solves"])


def test_land_can_weigh_the_spin_the_touchdown_impact_leaves(tmp_path):
    """A new user's landing touched down upright and then spun at 7.7 rad/s: the impact's
    lever arm CS x n was not in the goal (issue 34).  land.toml with P free at the end:
    unweighed, the impact leaves 18.9 rad/s; with spin_weight = 0.1 under 1 rad/s, the
    attitude still met.  The spin after the impact is checked against an independent
    Newton-Euler run of the written plan (its own impact of the two bodies)."""
    doc = tomllib.loads((EXAMPLES / "land.toml").read_text())
    doc["plan"]["rest_at_ends"] = False
    spins = []
    for weight in (None, 0.1):
        if weight is not None:
            doc["plan"]["spin_weight"] = weight
        w = Written(make_plan(copy.deepcopy(doc)), tmp_path / str(weight))
        s = w.summary
        assert s["status"] == "solved"
        reported = s["achieved"]["runtime"]["spin_after"]
        _, _, impacts, _ = newton_euler_run(w, w.scene["run"]["duration"], max_impacts=1)
        ne = float(np.linalg.norm(impacts[0]["after"][6:9]))
        assert abs(reported - ne) < 1e-6 * max(ne, 1.0), (reported, ne)
        assert s["achieved"]["runtime"]["attitude_error_rad"] < 1e-8
        spins.append(ne)
    assert spins[0] > 10.0 and spins[1] < 1.0, spins


@pytest.mark.parametrize("goal", ["reorient", "hop"])
def test_spin_weight_belongs_to_land(goal):
    doc = tomllib.loads((EXAMPLES / f"{goal}.toml").read_text())
    doc["plan"]["spin_weight"] = 1.0
    with pytest.raises(SceneError, match=r"^\[plan\]\.spin_weight: belongs to goal = "
                                         r"\"land\""):
        load_task(doc)

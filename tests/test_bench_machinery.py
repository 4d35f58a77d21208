"""The benchmarks' machinery (not their timings): charts, data and ratios are produced,
and the errors they report are measured against the exact references."""
from __future__ import annotations

import json

import numpy as np
import pytest

from derive.bench import precision
from derive.bench.routes import Runtime, Scipy, errors


def test_precision_quick_run_writes_charts_and_data(tmp_path):
    summary = precision.run(tmp_path, quick=True, repeats=1, periods=20,
                            scenes=["vertical bounce C2.4"])
    assert (tmp_path / "precision_vertical.png").is_file()
    assert (tmp_path / "long_run.png").is_file()
    data = json.loads((tmp_path / "precision.json").read_text())
    methods = {p["method"] for p in data["points"]}
    assert {"runtime DOP853", "scipy DOP853", "casadi cvodes", "scipy Radau"} <= methods
    matched = summary["scenes"]["vertical bounce C2.4"]["matched"]
    assert matched[0]["level"] == 1e-4 and np.isfinite(matched[0]["runtime_best_s"])
    lines = (tmp_path / "precision.csv").read_text().splitlines()
    assert lines[0].startswith("scene,method,setting,seconds,error")
    # the long run's invariants: the momentum form keeps K and A to round-off; projection
    # keeps A orthonormal to the error of the dense output between steps
    drift = summary["long_run"]
    lie = drift["runtime LIE"]
    assert lie["K_max"] < 1e-14 and lie["K_fixed_max"] < 1e-14
    assert lie["orthonormality_max"] < 1e-14
    assert drift["runtime DOP853+orth"]["orthonormality_final"] < 1e-11
    assert drift["runtime DOP853"]["K_fixed_max"] > 100 * lie["K_fixed_max"]


def test_errors_are_against_the_closed_form():
    doc, exact = precision.reference_scenes()["vertical bounce C2.4"]
    from derive.scene import parse_scene
    route = Runtime(doc, "dop853", 1e-12)
    states, impacts = exact(parse_scene(doc), route.grid)
    from derive.bench.routes import Run
    ref = Run(states, impacts, 0, "done")
    err, ierr = errors(route.result(), ref)
    assert err < 1e-11 and ierr < 1e-12
    # the measure sees a loose tolerance (the bounce itself is a parabola that every
    # method integrates exactly; the axisymmetric scene is not)
    doc, exact = precision.reference_scenes()["axisymmetric E3.14"]
    route = Scipy(doc, "RK45", 1e-4)
    ref = Run(exact(parse_scene(doc), route.grid)[0], np.array([]), 0, "done")
    loose, _ = errors(route.result(), ref)
    assert loose > 1e-8


@pytest.mark.parametrize("form", ["coriolis", "euler", "euler_scaled"])
def test_hand_written_peer_equals_the_derivation(form):
    """The peers of `derive bench rhs` (E1.2, E1.7, E1.8 typed in CasADi, casadi.solve,
    in each form) compute the same right-hand side as the derived one, at the 200
    physical states."""
    from derive.bench.rhs import HAND_FORMS, hand_written_flight_rhs, physical_inputs
    from derive.emit.numpy_backend import compile_spec
    from derive.models import flight_rhs
    assert form in HAND_FORMS
    hand = hand_written_flight_rhs(form)
    ours = compile_spec(flight_rhs("general"))
    for q, u, p in physical_inputs(200):
        a = np.array(hand(q, u, p).full()).ravel()
        b = np.asarray(ours(q, u, p)[0])
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b))


@pytest.mark.parametrize("solver", ["ldlt", "adjugate", "cholesky", "rank1-sm",
                                    "rank1-adjugate"])
def test_every_closed_form_solve_agrees_with_numpy(solver):
    """Each solve of derive.emit.linalg on SPD matrices E1.5 can give: diag(J_i + mu
    |r|^2) - mu r r^T with J of a real mass distribution; the solvers that read the
    entries also on general SPD matrices.  One, two and four right-hand sides (four: the
    adjugate forms the inverse's entries once)."""
    from derive.emit.linalg import SOLVERS, STRUCTURED
    rng = np.random.default_rng(1)
    for k in range(60):
        second = rng.uniform(0.02, 1.0, 3)
        J = np.array([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
        mu, r = rng.uniform(0.05, 2.0), rng.uniform(-1, 1, 3)
        A = np.diag(J + mu * r @ r) - mu * np.outer(r, r)
        if solver not in STRUCTURED and k % 2:
            B = rng.normal(size=(3, 3))
            A = B @ B.T + 0.1 * np.eye(3)
        b = [rng.normal(size=3) for _ in range(1 + k % 3 + (k % 3 == 2))]
        if solver in STRUCTURED:
            given = (*(J + mu * r @ r), *(mu * r), *r)
        else:
            given = (A[0, 0], A[1, 0], A[1, 1], A[2, 0], A[2, 1], A[2, 2])
        for x, rhs in zip(SOLVERS[solver](given, b), b):
            np.testing.assert_allclose(x, np.linalg.solve(A, rhs), rtol=1e-9, atol=1e-12)


def test_latency_analysis_of_a_known_chain():
    """x' = (q0 q1 + u0) / (u1 + u2), printed as (q0 q1 + u0) * (1/(u1 + u2)): from q a
    multiply, an add and the multiply by the reciprocal, which reads the law alone and is
    off the chain; from every input the reciprocal (an add and a division) is on it."""
    import sympy as sp
    from derive.emit.latency import analyse
    from derive.emit.program import build
    from derive.models import FunctionSpec, Vector
    q0, q1, u0, u1, u2 = sp.symbols("q0 q1 u0 u1 u2", real=True)
    spec = FunctionSpec("toy", "", (Vector("q", (q0, q1), ("a", "b")),
                                    Vector("u", (u0, u1, u2), ("c", "d", "e"))),
                        (Vector("x", ((q0 * q1 + u0) / (u1 + u2),), ("x",)),))
    lat = {"add": 1.0, "mul": 2.0, "div": 10.0, "sqrt": 20.0, "call": 50.0}
    hot = analyse(build(spec), ("q",), lat)
    assert hot.path.counts == {"mul": 2, "add": 1} and hot.path.time == 5.0
    assert hot.totals == {"add": 2, "mul": 2, "div": 1, "sqrt": 0, "call": 0}
    every = analyse(build(spec), ("q", "u"), lat)
    assert every.path.counts == {"add": 1, "div": 1, "mul": 1} and every.path.time == 13.0


def test_rhs_latency_floor_function_computes_its_products():
    """The floor of `derive bench rhs`'s latency loop compiles with the strict warnings
    (build_shared) and computes dq[k] = q[k] u[k mod 9], as its report says."""
    import ctypes

    from derive.bench.rhs import FLOOR, _floor_source
    from derive.cbuild import build_shared
    from derive.models import flight_rhs
    text, _ = _floor_source(flight_rhs("general"))
    lib = ctypes.CDLL(str(build_shared({f"{FLOOR}.c": text}, name="floor")))
    dp = ctypes.POINTER(ctypes.c_double)
    fn = getattr(lib, FLOOR)
    fn.argtypes, fn.restype = [dp] * 4, None
    rng = np.random.default_rng(5)
    q, u, p, dq = rng.normal(size=18), rng.normal(size=9), rng.normal(size=6), np.empty(18)
    fn(*(a.ctypes.data_as(dp) for a in (q, u, p, dq)))
    assert np.array_equal(dq, q * u[np.arange(18) % 9])


def test_rhs_bound_is_the_emitted_rhs_at_its_fixed_law():
    """The bound of `derive bench rhs` (the emitted flight RHS with the law and parameters
    compile-time constants) compiles with the strict warnings and computes what the
    emitted RHS computes at those law values, whatever the state and the u and p passed."""
    import ctypes

    from derive.bench.rhs import BOUND, _bound_source, physical_inputs
    from derive.cbuild import build_shared
    from derive.emit.render import GENERATED
    from derive.models import flight_rhs
    text, _ = _bound_source(flight_rhs("general"))
    assert "u[" not in text.split("{", 1)[1] and "p[" not in text.split("{", 1)[1]
    bound = getattr(ctypes.CDLL(str(build_shared({f"{BOUND}.c": text}, name="bound"))), BOUND)
    src = {p.name: p.read_text() for p in (GENERATED / "c").glob("*.h")}
    src["general_flight_rhs.c"] = (GENERATED / "c" / "general_flight_rhs.c").read_text()
    emitted = ctypes.CDLL(str(build_shared(src, name="emitted"))).carrier_general_flight_rhs
    dp = ctypes.POINTER(ctypes.c_double)
    for fn in (bound, emitted):
        fn.argtypes, fn.restype = [dp] * 4, None
    _, u, p = physical_inputs(1)[0]
    for q, _, _ in physical_inputs(20, seed=3):
        got, want = np.empty(18), np.empty(18)
        junk_u, junk_p = np.full(9, np.nan), np.full(6, np.nan)
        bound(*(a.ctypes.data_as(dp) for a in (q, junk_u, junk_p, got)))
        emitted(*(np.ascontiguousarray(a).ctypes.data_as(dp) for a in (q, u, p, want)))
        assert np.allclose(got, want, rtol=1e-13, atol=1e-13)


def test_work_precision_curves_are_read_between_runs():
    """time_on_curve interpolates a method's time in log-log between the two tolerances
    whose errors straddle the level; time_at takes the least time among runs within it."""
    P = precision.Point

    def pts(method, rows):
        return [P("s", method, tol, sec, err, 0.0, 0, "done") for tol, sec, err in rows]
    a = pts("a", [(1e-9, 1.0, 2e-10), (1e-10, 2.0, 5e-11), (1e-11, 4.0, 1e-12)])
    assert precision.time_at(a, "a", 1e-10, False) == 2.0
    assert abs(precision.time_on_curve(a, "a", 1e-10, False) - 2 ** 0.5) < 1e-12
    # at or below a run's own error the run itself; beyond the tightest, never reached
    assert precision.time_on_curve(a, "a", 5e-11, False) == 2.0
    assert np.isnan(precision.time_on_curve(a, "a", 1e-13, False))
    # a level the errors cross twice (an erratic method): the cheaper crossing
    b = pts("b", [(1e-9, 1.0, 2e-10), (1e-10, 2.0, 5e-11), (1e-11, 3.0, 4e-10),
                  (1e-12, 8.0, 1e-11)])
    assert abs(precision.time_on_curve(b, "b", 1e-10, False) - 2 ** 0.5) < 1e-12
    # the verdict: LIE read on its curve against the classical methods on theirs
    rows = precision.default_against_classical(
        pts("runtime LIE", [(3e-13, 0.071, 1.19e-12), (1e-13, 0.082, 1.9e-13)])
        + pts("runtime DOP853", [(1e-12, 0.0725, 2.2e-12), (3e-13, 0.0805, 7.8e-13)]),
        False)
    row = next(r for r in rows if r["level"] == 1e-12)
    assert row["ok"] and not row["grid_ok"]
    assert row["default_s"] < 0.0725 and row["grid_default_s"] == 0.082


def test_bodies_bench_sees_a_swell_and_builds_its_scenes():
    """derive bench bodies: a cost growing as (N + R)^2 is refused by its no-swell fit (a
    linear one is not), and its scenes carry the bodies they say."""
    from derive.bench import bodies
    from derive.bench.timing import Spread
    from derive.scene import parse_scene

    def grid(cost):
        return {(n, r): {"per_evaluation": Spread.of([cost(n, r)])}
                for n in bodies.POINTS for r in bodies.ROTORS}
    _, linear = bodies.linear_fit(grid(lambda n, r: 1.0 + 0.4 * n + 0.1 * r))
    _, square = bodies.linear_fit(grid(lambda n, r: 1.0 + 0.4 * (n + r) ** 2))
    assert linear < 1.0 + 1e-12 and square > bodies.SWELL
    sc = parse_scene(bodies.scene(8, 4))
    assert (len(sc.points), len(sc.rotors)) == (8, 4)
    assert parse_scene(bodies.scene(1, 0)).one_point

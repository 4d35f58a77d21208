"""The point law at run time: the C interpreter, NumPy and SymPy agree on random laws of
the grammar; the interval proof finds singular points from the expression; tabulated
laws are SciPy's cubic splines."""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from cases import random_law
from derive.runtime.driver import prepare
from derive.runtime.session import Session
from derive.scene.law import compile_law, find_singularity, parse_law
from derive.scene import SceneError, builtin_doc, parse_scene


def _session(law_texts):
    doc = builtin_doc()
    doc.pop("plane")
    doc["point"]["law"] = list(law_texts)
    doc["point"]["max_distance"] = 1e6
    doc["run"]["duration"] = 2.0
    prep = prepare(doc)
    s = Session(prep.library)
    s.set_law(prep.scene.law)
    s.init(prep.options, prep.parameters, 0.0, prep.start.q0)
    return prep, s


def test_interpreter_numpy_and_sympy_agree_on_random_laws():
    rng = np.random.default_rng(7)
    ts = np.linspace(0.0, 2.0, 11)
    t = sp.Symbol("t", real=True)
    checked = 0
    for _ in range(60):
        texts = [random_law(rng, 4) for _ in range(3)]
        try:
            prep, s = _session(texts)
        except SceneError:
            continue                       # e.g. P beyond max_distance: not this test
        program = prep.scene.law
        c = s.law_rows(ts)                 # (N, 9): x, y, z, x', y', z', x'', y'', z''
        npj = program.jets(ts)             # (9, N): x, x', x'', y, ...
        exprs = program.sympy()
        for k in range(3):
            f = [sp.lambdify(t, sp.diff(exprs[k], t, d), "math") for d in range(3)]
            for d in range(3):
                ref = np.array([float(f[d](tv)) for tv in ts])
                scale = 1.0 + np.max(np.abs(ref))
                assert np.max(np.abs(c[:, 3 * d + k] - ref)) < 1e-11 * scale, texts[k]
                assert np.max(np.abs(npj[3 * k + d] - ref)) < 1e-11 * scale, texts[k]
        checked += 1
    assert checked >= 40


def _ulps(got: np.ndarray, exact: list) -> np.ndarray:
    """|got - exact| in units of the spacing of doubles at the exact value."""
    return np.array([abs(float(g) - e) / math.ulp(abs(float(e))) if e != 0 else abs(g)
                     for g, e in zip(got, exact)])


def test_runtime_sine_and_cosine_within_one_ulp():
    """crt_sincos (derive/emit/sincos.py) against 40-digit mpmath: harmonics (the op of
    A sin|cos(w t + p)) and sin of a computed argument, over small and large arguments,
    arguments next to multiples of pi/2 (where the reduction cancels) and beyond the
    kernel's range (the C library's sin and cos), up to 5 % beyond it included."""
    import mpmath as mp
    rng = np.random.default_rng(11)
    near = [float(mp.mpf(int(k)) * mp.pi / 2) for k in rng.integers(1, 10 ** 6, 300)]
    near += [np.nextafter(x, np.inf) for x in near] + [np.nextafter(x, -np.inf) for x in near]
    ts = np.r_[rng.uniform(-4, 4, 400), rng.uniform(-1e3, 1e3, 400),
               rng.uniform(-1.5e6, 1.5e6, 400), near, rng.uniform(1.6e6, 1e12, 100),
               # past the kernel's range by up to 5 %, where k = round(2 x / pi) >= 2^20
               # makes k pi/2's first part inexact (the C library's there)
               rng.uniform(1.6472e6, 1.6515e6, 50),
               0.0, -0.0, 1e-300, math.pi / 4, 3 * math.pi / 4]
    _, s = _session(["sin(t)", "cos(t)", "sin(t*t)"])
    u = s.law_rows(ts)
    with mp.workdps(40):
        sin_t = [mp.sin(mp.mpf(float(t))) for t in ts]
        cos_t = [mp.cos(mp.mpf(float(t))) for t in ts]
        sin_tt = [mp.sin(mp.mpf(float(t) * float(t))) for t in ts]
    for column, exact, what in ((0, sin_t, "A sin(w t + p)"), (1, cos_t, "A cos(w t + p)"),
                                (3, cos_t, "d/dt A sin(w t + p)"), (2, sin_tt, "sin(x)")):
        err = _ulps(u[:, column], exact)
        assert np.max(err) <= 1.0, (what, ts[int(np.argmax(err))], np.max(err))


@pytest.mark.parametrize("text,t_sing", [
    ("0.001/(t - 1)", 1.0), ("0.001*tan(t)", math.pi / 2), ("sqrt((t - 0.3)^2)", 0.3),
    ("log(1.5 - t)", 1.5), ("0.01*asin(0.5*t)", 2.0), ("(t - 2.5)^-2", 2.5),
    ("0.1*(0.7 - t)^1.5", 0.7), ("1/(sin(t)*cos(t) + 2) + 1/(t^2 - 2)", math.sqrt(2)),
])
def test_singular_points_are_found_from_the_expression(text, t_sing):
    sing = find_singularity(parse_law(text), 0.0, 3.0)
    assert sing is not None and sing.coordinate == 0
    assert abs(sing.t - t_sing) < 1e-9


@pytest.mark.parametrize("text,t0,t1,t_sing", [
    ("0.01/cos(t)", 0.0, 3.0, math.pi / 2), ("0.01/sin(t + 1)", 0.0, 3.0, math.pi - 1),
    ("1/sin(t)", 0.5, 3.5, math.pi), ("0.01/cos(3*t)", 0.5, 3.5, math.pi / 6),
    ("0.1/sin(2*t - 1)", 1.0, 4.0, (1 + math.pi) / 2), ("0.01/sin(-t + 5)", 0.0, 3.0, 5 - math.pi),
    ("0.01/sin(t/10 + 0.5)", 20.0, 40.0, 10 * (math.pi - 0.5)),
])
def test_a_harmonic_divisor_is_singular_where_it_vanishes(text, t0, t1, t_sing):
    """A harmonic (A sin(w t + p), one node of the program) is enclosed over a box of t
    by the sine of its argument's box, not by [-A, A]: a division by it is proved
    regular away from its zeros and refused at the first one, named to 1e-9 (it had been
    refused at the run's start however far its zero)."""
    sing = find_singularity(parse_law(text), t0, t1)
    assert sing is not None and abs(sing.t - t_sing) < 1e-9, sing


@pytest.mark.parametrize("text,t0,t1", [
    ("0.01/cos(t)", 0.0, 1.5), ("0.01/sin(t + 1)", 0.0, 2.0), ("0.01/sin(t/10 + 0.5)", 0.0, 10.0),
    ("1/sin(t)", 0.5, 3.0), ("0.01/cos(3*t)", -0.5, 0.5), ("1/(2*cos(t) - 3)", 0.0, 30.0),
])
def test_a_harmonic_divisor_away_from_its_zeros_is_proved_regular(text, t0, t1):
    assert find_singularity(parse_law(text), t0, t1) is None


@pytest.mark.parametrize("text", ["1/(1 + t^2)", "sqrt(2 + sin(t))", "log(2 + cos(3*t))",
                                  "0.1*tan(0.4*t)", "asin(0.5*sin(t))", "t^3 - 2*t",
                                  "exp(-t)*cos(5*t)", "2^t"])
def test_smooth_laws_are_proved_smooth(text):
    assert find_singularity(parse_law(text), 0.0, 3.0) is None


def test_a_pole_between_samples_is_refused_naming_the_coordinate():
    doc = builtin_doc()
    doc["point"]["law"] = ["0.2*sin(3*t)", "0.001/(t - 1.0000001)", "0"]
    with pytest.raises(SceneError) as info:
        parse_scene(doc)
    assert info.value.where == "[point].law[1]"
    assert "not twice differentiable" in info.value.rule and "1.0000001" in info.value.rule


def test_the_opcodes_are_the_abis():
    """The law modules' opcodes and the C interpreter's (numbered by derive.abi) are one
    list, in one order."""
    from derive import abi
    from derive.scene.law import OPS
    assert tuple(OPS) == abi.names(abi.OPCODES)


def test_constant_subexpressions_and_sharing():
    p = compile_law(("2*exp(3*t) + exp(3*t)", "exp(3*t)", "pi^2"))
    assert sum(op == "exp" for op in p.ops) == 1           # shared
    # a harmonic A sin(w t + p) is one node of the interpreter
    h = compile_law(("0.2*sin(3*t + 0.5)", "-0.1*cos(t/2 - 1)", "0"))
    assert [op for op in h.ops if op not in ("const",)] == ["hsin", "hcos"]
    assert p.is_constant(2) and p.constant(2) == pytest.approx(math.pi ** 2)
    assert compile_law(("t - t", "0", "0")).is_zero(0)


def _table_doc(rows, ends, duration=1.0):
    doc = builtin_doc()
    doc["point"] = {"mass": 0.2, "samples": [list(map(float, r)) for r in rows],
                    "ends": ends}
    doc["run"]["duration"] = duration
    return doc


def test_tabulated_law_is_scipys_cubic_spline():
    from scipy.interpolate import CubicSpline
    ts = np.linspace(0.0, 2.0, 21)
    xyz = np.column_stack([0.1 * np.sin(2 * ts), 0.05 * ts, 0.02 * np.cos(ts)])
    prep = prepare(_table_doc(np.column_stack([ts, xyz]), "free", 2.0))
    s = Session(prep.library)
    s.set_law(prep.scene.law)
    s.init(prep.options, prep.parameters, 0.0, prep.start.q0)
    tq = np.linspace(0.0, 2.0, 97)
    got = s.law_rows(tq)
    cs = CubicSpline(ts, xyz, bc_type="not-a-knot")
    for d in range(3):
        ref = cs(tq, d)
        assert np.max(np.abs(got[:, 3 * d:3 * d + 3] - ref)) < 1e-12
        assert np.max(np.abs(prep.scene.law.jets(tq)[[d, 3 + d, 6 + d]].T - ref)) < 1e-12


def test_periodic_table_wraps_and_matches_its_formula():
    """A periodic table sampled from 0.2 sin(3t) finely reproduces the formula law's
    run (to the spline's accuracy), also after several periods."""
    period = 2 * math.pi / 3
    ts = np.linspace(0.0, period, 801)
    rows = np.column_stack([ts, 0.2 * np.sin(3 * ts), np.full_like(ts, 0.1),
                            0.05 * np.cos(3 * ts)])
    rows[-1, 1:] = rows[0, 1:]
    table = _table_doc(rows, "periodic", 4.0)
    formula = builtin_doc()
    formula["point"]["law"] = ["0.2*sin(3*t)", "0.1", "0.05*cos(3*t)"]
    formula["run"]["duration"] = 4.0
    from derive.runtime.driver import simulate
    a, b = simulate(table), simulate(formula)
    assert a.status == b.status == "done" and len(a.impacts) == len(b.impacts)
    assert np.max(np.abs(a.impacts[:, 0] - b.impacts[:, 0])) < 1e-7
    assert np.max(np.abs(a.q[-1] - b.q[-1])) < 1e-6


@pytest.mark.parametrize("knots, method", [(41, "lie"), (41, "dop853"), (513, "dop853"),
                                           (13, "dopri5")])
def test_a_tabulated_law_keeps_the_tolerance(knots, method):
    """The spline's third derivative jumps at each knot, which the error estimate of a
    step across it misjudges: steps that would cross one knot end on it.  A tumbling
    carrier in free flight, the point on a periodic table, at the default tolerance:
    the final state is within 1e-9 of a run by another method at 1e-14, across
    periodic wraps.  Before steps ended on knots: 1.3e-8 to 1.4e-7 (lie, DOP853 and
    DOPRI5 with 13 to 513 knots), and DOP853 took 11 to 27 times as many evaluations of
    the right-hand side, most of its steps rejected."""
    from derive.runtime.driver import simulate
    from cases import table_flight
    period = 2 * math.pi / 3
    doc = table_flight(np.linspace(0.0, period, knots), 3 * period, method=method)
    run = simulate(doc)
    # the reference by another method (the same one at 1e-14 can take the same steps)
    doc["run"].update(method="lie8" if method == "dop853" else "dop853", rtol=1e-14,
                      atol=1e-16)
    ref = simulate(doc)
    assert run.model == ref.model and run.status == ref.status == "done"
    assert np.max(np.abs(run.q[-1] - ref.q[-1])) < 1e-9
    assert run.stats["rejected"] <= run.stats["steps"] // 4


def test_rk4_steps_end_on_each_knot_never_longer():
    """RK4 (no error control to catch a step across a knot) on table_flight's periodic
    table of 41 knots, 52 ms apart, with a step of 4 ms: a row at every step, and the
    rows' times are the grid computed here from the rule alone: steps of 4 ms from each
    knot, the last one before the next knot cut to end on it, across the table's
    periodic wrap at 2.09 s, then the end.  (crt_loop.h: a step that would end within 5 %
    of a knot's time short of it is not stretched to the knot, and one that would cross
    a knot by less than 5 % of its time, or by more than the step, is cut.)"""
    from derive.runtime.driver import simulate
    from cases import table_flight
    period, step, duration = 2 * math.pi / 3, 0.004, 2.5
    knots = np.linspace(0.0, period, 41)
    doc = table_flight(knots, duration, method="rk4", step=step, output_dt=0.0)
    res = simulate(doc, progress=False)
    assert res.status == "done"
    every = np.concatenate([knots[1:] + k * period for k in range(2)])
    grid, t = [0.0], 0.0
    while t < duration:
        knot = every[np.searchsorted(every, t + 1e-9, side="right")]
        t = min(t + step, knot, duration)
        grid.append(t)
    assert len(res.t) == len(grid)
    np.testing.assert_allclose(res.t, grid, rtol=0, atol=1e-12)
    assert np.max(np.diff(res.t)) <= step * (1 + 1e-12)
    assert np.isin(np.round(every[every < duration], 9), np.round(res.t, 9)).all()


def test_a_run_beyond_a_free_table_is_refused():
    ts = np.linspace(0.0, 1.0, 11)
    doc = _table_doc(np.column_stack([ts, 0 * ts, 0 * ts, 0 * ts]), "free", 2.0)
    with pytest.raises(SceneError, match=r"^\[point\]\.samples: covers t in \[0, 1\]"):
        parse_scene(doc)                 # the field the scene gave (it named table)

"""crt_face.h, the base model's friction over a face in C, against derive/face.py (the same
integrals in NumPy: the rules are the same nodes, crt_face_rules.h rendered from
derive/face.py's orders) and against the reference's adaptive quadrature
(derive/base_reference.py), through a small shim compiled once (a few functions of the
header exported to ctypes).

* The wrench and D on random twists about instant centres within 12 face sizes (the
  closed form, the disc's rules, the far product rule and translations), uniform and
  linear pressure: a rectangle to 1e-12 of the largest component, a disc to 1e-12.
* A disc's instant centre within 0.05 R of its rim, inside, on it and outside: the C and
  face.py (the closed form there) against SciPy's adaptive quadrature over the angle
  (split where the chord's root nearly vanishes) to 1e-12; the closed form meets the
  rules at the band's ends to round-off.
* The gauge: the closed forms (a force through the pressure centre |F|/(mu N), a torque
  on a centred disc |T|/((2/3) mu N R)), face.gauge's on random wrenches to 1e-10, and
  the support property (the slip's friction at xi* is -W/gamma); under uniform pressure
  its bounds from the force's and the torque's parts bracket face.gauge's, the mean
  distance they read is the D of a unit spin about the centroid (the wrench's integrals),
  and a wrench that is one part to round-off takes the closed form, no evaluation.
"""
import ctypes
import math
import warnings

import numpy as np
import pytest
from scipy.integrate import IntegrationWarning, quad

from derive import base_reference as br
from derive import face as fc
from derive.cbuild import build_shared
from derive.runtime.build import runtime_dir

RNG = np.random.default_rng(33)
SHIM = r"""
#include "crt_face.h"
double shim_wrench(int kind, const double *geom, double N, const double *k, double mu,
                   const double *tw, double *W)
{
  crt_face f;
  crt_face_set(&f, kind, geom[0], geom[1], geom[2], geom[3]);
  return crt_face_wrench(&f, N, k, mu, tw, W);
}
/* one slip's integrals (crt_face_slip_set), read under n pressures (k: n pairs) */
double shim_apply(int kind, const double *geom, double N, const double *k, double mu,
                  const double *tw, double *W, long n)
{
  crt_face f;
  crt_face_slip m;
  double D = 0.0;
  long j;
  crt_face_set(&f, kind, geom[0], geom[1], geom[2], geom[3]);
  crt_face_slip_set(&f, 1, tw, &m);
  for (j = 0; j < n; ++j) D = crt_face_apply(&f, &m, N, k + 2 * j, mu, W + 3 * j);
  return D;
}
double shim_gauge(int kind, const double *geom, double N, const double *k, double mu,
                  const double *W, double *xi, long *evaluations)
{
  crt_face f;
  crt_face_set(&f, kind, geom[0], geom[1], geom[2], geom[3]);
  return crt_face_gauge(&f, N, k, mu, W, xi, evaluations);
}
double shim_bounds(int kind, const double *geom, double N, const double *k, double mu,
                   const double *W, double *lohi)
{
  crt_face f;
  int part;
  crt_face_set(&f, kind, geom[0], geom[1], geom[2], geom[3]);
  crt_face_gauge_bounds(&f, N, k, mu, W, lohi, lohi + 1, &part);
  lohi[2] = part;
  return f.rbar;
}
double shim_edge(int kind, const double *geom, double x, double y)
{
  crt_face f;
  crt_face_set(&f, kind, geom[0], geom[1], geom[2], geom[3]);
  return crt_face_edge_margin(&f, x, y);
}
double shim_kern(int kind, const double *geom, double x, double y, double N, double *k)
{
  crt_face f;
  const double cp[2] = {x, y};
  crt_face_set(&f, kind, geom[0], geom[1], geom[2], geom[3]);
  crt_face_slope(&f, 1, N, cp, k);
  return crt_face_kern_margin(&f, x, y);
}
"""
DP = ctypes.POINTER(ctypes.c_double)


@pytest.fixture(scope="module")
def shim():
    folder = runtime_dir()
    sources = {n: (folder / n).read_bytes() for n in ("crt_face.h", "crt_face_rules.h")}
    lib = ctypes.CDLL(str(build_shared({**sources, "shim_face.c": SHIM}, name="shim_face")))
    for name, extra in (("shim_wrench", []), ("shim_gauge", [ctypes.POINTER(ctypes.c_long)])):
        fn = getattr(lib, name)
        fn.restype = ctypes.c_double
        fn.argtypes = [ctypes.c_int, DP, ctypes.c_double, DP, ctypes.c_double, DP, DP, *extra]
    lib.shim_apply.restype = ctypes.c_double
    lib.shim_apply.argtypes = [ctypes.c_int, DP, ctypes.c_double, DP, ctypes.c_double, DP, DP,
                               ctypes.c_long]
    lib.shim_bounds.restype = ctypes.c_double
    lib.shim_bounds.argtypes = [ctypes.c_int, DP, ctypes.c_double, DP, ctypes.c_double, DP, DP]
    lib.shim_edge.restype = ctypes.c_double
    lib.shim_edge.argtypes = [ctypes.c_int, DP, ctypes.c_double, ctypes.c_double]
    lib.shim_kern.restype = ctypes.c_double
    lib.shim_kern.argtypes = [ctypes.c_int, DP, ctypes.c_double, ctypes.c_double,
                              ctypes.c_double, DP]
    return lib


def _arr(x):
    return np.ascontiguousarray(x, dtype=float)


def _ptr(a):
    return a.ctypes.data_as(DP)


def _face_args(f, N, cp, mode):
    kind = 0 if f.kind == "rectangle" else 1
    half = (*f.half, 0.0)[:2]
    _, k = fc.pressure_slope(f, N, cp, mode)
    return kind, _arr([half[0], half[1], *f.centre]), _arr(k)


def c_wrench(lib, f, N, cp, mode, mu, tw):
    kind, geom, k = _face_args(f, N, cp, mode)
    W = np.zeros(3)
    D = lib.shim_wrench(kind, _ptr(geom), N, _ptr(k), mu, _ptr(_arr(tw)), _ptr(W))
    return W, D


def c_gauge(lib, f, N, cp, mode, mu, W, start=(0.0, 0.0, 0.0)):
    kind, geom, k = _face_args(f, N, cp, mode)
    xi = _arr(start)
    count = ctypes.c_long(0)
    gam = lib.shim_gauge(kind, _ptr(geom), N, _ptr(k), mu, _ptr(_arr(W)), _ptr(xi),
                         ctypes.byref(count))
    return gam, xi, count.value


def _faces():
    box = fc.face_on("box", (0.2, 0.1, 0.05), (0.01, -0.01, 0), (0, 0, 1))
    disc = fc.face_on("cylinder", (0.1, 0.05), (0.01, -0.01, 0), (0, 0, 1))
    for f in (box, disc):
        for mode, cp in (("uniform", None), ("linear", (0.015, -0.005))):
            yield f, mode, cp


def _twists(f, count):
    for j in range(count):
        r0 = np.asarray(f.centre) + RNG.uniform(-12, 12, 2) * f.size * RNG.uniform(0, 1) ** 2
        w = RNG.choice([-1, 1]) * RNG.uniform(0.5, 3)
        if j % 10 == 9:                            # a translation, w at 1e-14 of |v| / size
            th = RNG.uniform(0, 2 * np.pi)
            yield (w * math.cos(th), w * math.sin(th), 1e-14 * w / f.size)
            continue
        yield (r0[1] * w, -r0[0] * w, w)


def test_the_wrench_is_face_pys_and_the_references(shim):
    N, mu = 2.0, 0.5
    far = 0
    for f, mode, cp in _faces():
        system = br.System(M=1, J=(1, 1, 1), face=f, pressure=mode)
        for tw in _twists(f, 60):
            W, D = c_wrench(shim, f, N, cp, mode, mu, tw)
            py, D_py = fc.centre_wrench(f, N, cp, mode, mu, tw)
            scale = np.abs(py).max()
            assert np.abs(W - py).max() <= 1e-12 * scale, (f.kind, mode, tw)
            assert abs(D - D_py) <= 1e-12 * D_py
            if mode == "uniform":
                ref, D_ref = br.friction(system, mu, N, cp, tw)
                assert np.abs(W - ref).max() <= 1e-12 * scale
                assert abs(D - D_ref) <= 1e-12 * D_ref
            r0 = np.array([-tw[1], tw[0]]) / tw[2]
            far += fc.FAR * f.size < np.hypot(*(r0 - f.centre)) < 1e6 * f.size
    assert far > 10                        # the product rule was exercised


def test_one_slips_integrals_give_its_wrench_under_every_pressure(shim):
    """The integrals of a slip taken once (crt_face_slip_set; crt_base_linear reads four
    pressures from them) give, under each pressure, the wrench crt_face_wrench gives
    (the same bits) and the reference's adaptive quadrature's to 1e-12."""
    N, mu = 2.0, 0.5
    cps = (None, (0.015, -0.005), (-0.01, 0.012))
    for f, mode, _ in _faces():
        if mode != "linear":
            continue
        system = br.System(M=1, J=(1, 1, 1), face=f, pressure=mode)
        kind, geom, _ = _face_args(f, N, None, mode)
        ks = _arr([fc.pressure_slope(f, N, cp, "uniform" if cp is None else mode)[1]
                   for cp in cps])
        for tw in _twists(f, 10):
            W = np.zeros((len(cps), 3))
            shim.shim_apply(kind, _ptr(geom), N, _ptr(ks), mu, _ptr(_arr(tw)), _ptr(W), len(cps))
            for j, cp in enumerate(cps):
                alone, _ = c_wrench(shim, f, N, cp, "uniform" if cp is None else mode, mu, tw)
                assert np.array_equal(W[j], alone)
                ref, _ = br.friction(system, mu, N, cp or tuple(f.centre), tw)
                assert np.abs(W[j] - ref).max() <= 1e-12 * np.abs(ref).max(), (f.kind, cp, tw)


def test_the_edge_margin_is_face_pys(shim):
    for f, _, _ in _faces():
        kind, geom, _ = _face_args(f, 1.0, None, "uniform")
        for p in RNG.uniform(-0.3, 0.3, (50, 2)):
            assert shim.shim_edge(kind, _ptr(geom), *p) == pytest.approx(f.edge_margin(p),
                                                                        abs=1e-15)


def test_the_kern_margin_and_the_linear_slope_are_face_pys(shim):
    """Linear pressure's kern (where the run stops with face_lifting) and its slope k from
    the centre of pressure, as derive/face.py has them; and k's pressure has its centroid
    at cp (the first moments of the product rule, a third way)."""
    N = 2.5
    for f, _, _ in _faces():
        kind, geom, _ = _face_args(f, 1.0, None, "uniform")
        rl = fc.rule(f, 12)
        for p in RNG.uniform(-0.1, 0.1, (30, 2)):
            k = _arr([0.0, 0.0])
            margin = shim.shim_kern(kind, _ptr(geom), *p, N, _ptr(k))
            assert margin == pytest.approx(f.kern_margin(p), abs=1e-15)
            assert np.allclose(k, fc.pressure_slope(f, N, p, "linear")[1], rtol=1e-14, atol=0)
            pw = rl.weights * (N / f.area + rl.offsets @ k)
            assert np.allclose(pw @ rl.nodes / N, p, rtol=0, atol=1e-14)


def test_the_gauge_closed_forms_and_face_pys(shim):
    mu, N = 0.4, 3.0
    box = fc.face_on("box", (0.2, 0.1, 0.05), (0, 0, 0), (0, 0, 1))
    gam, xi, _ = c_gauge(shim, box, N, None, "uniform", mu, (0.5, -0.3, 0.0))
    assert math.isclose(gam, math.hypot(0.5, 0.3) / (mu * N), rel_tol=1e-12)
    assert np.allclose(xi, np.array([0.5, -0.3, 0]) / math.hypot(0.5, 0.3), atol=1e-9)
    disc = fc.face_on("cylinder", (0.1, 0.05), (0, 0, 0), (0, 0, 1))
    gam, _, _ = c_gauge(shim, disc, N, None, "uniform", mu, (0, 0, 0.05))
    assert math.isclose(gam, 0.05 / (2 / 3 * mu * N * 0.1), rel_tol=1e-12)
    evaluations = []
    for f, mode, cp in _faces():
        fr = fc.Friction(f, N, cp, mode, mu)
        for _ in range(6):
            W = RNG.normal(size=3) * np.array([1, 1, f.size])
            gam, xi, count = c_gauge(shim, f, N, cp, mode, mu, W)
            gam_py, xi_py = fc.gauge(fr, W, f.size)
            assert math.isclose(gam, gam_py, rel_tol=1e-10)
            assert np.allclose(xi, xi_py, atol=1e-6)
            fric, _ = c_wrench(shim, f, N, cp, mode, mu, xi * np.array([1.0, 1.0, 1.0 / f.size]))
            assert np.allclose(-fric * gam, W, rtol=0, atol=1e-7 * np.abs(W).max())
            # warm-started from its maximiser (W scaled: the same xi*) it needs far fewer
            # evaluations: their median under 0.62 of the cold searches' over 30 draws of
            # these 24 wrenches (ignoring the start, 0.75 of it at least)
            _, _, warm = c_gauge(shim, f, N, cp, mode, mu, W * (1 + 1e-3), start=xi)
            evaluations.append((count, warm))
    cold, warm = np.median(evaluations, axis=0)
    assert warm < 0.7 * cold, (cold, warm)


def test_the_gauge_bounds_bracket_it_and_the_closed_forms_take_no_evaluation(shim):
    mu, N = 0.4, 3.0
    for f, mode, cp in _faces():
        if mode != "uniform":
            continue
        kind, geom, k = _face_args(f, N, cp, mode)
        lohi = np.zeros(3)
        # the mean distance from the centroid: D of the unit spin about it, over mu N
        rbar = shim.shim_bounds(kind, _ptr(geom), N, _ptr(k), mu, _ptr(_arr([1.0, 0, 0])),
                                _ptr(lohi))
        c = f.centre
        _, D = fc.centre_wrench(f, N, cp, mode, mu, (c[1], -c[0], 1.0))
        assert math.isclose(rbar, D / (mu * N), rel_tol=1e-12)
        fr = fc.Friction(f, N, cp, mode, mu)
        for _ in range(8):
            W = RNG.normal(size=3) * np.array([1, 1, f.size])
            shim.shim_bounds(kind, _ptr(geom), N, _ptr(k), mu, _ptr(_arr(W)), _ptr(lohi))
            gam_py, _ = fc.gauge(fr, W, f.size)
            assert lohi[0] <= gam_py * (1 + 1e-10) and gam_py <= lohi[1] * (1 + 1e-10)
            assert lohi[0] < lohi[1]
        # one part alone, the other at 1e-16 of it: the closed form, with its maximiser
        F = np.array([0.7, -0.4])
        Tc = 1e-16 * np.hypot(*F) / (mu * N) * (mu * N * rbar)
        for W, want in ((np.array([*F, c[0] * F[1] - c[1] * F[0] + Tc]),
                         np.hypot(*F) / (mu * N)),
                        (np.array([1e-17, 0.0, 0.05]), 0.05 / (mu * N * rbar))):
            gam, xi, count = c_gauge(shim, f, N, cp, mode, mu, W)
            gam_py, xi_py = fc.gauge(fr, W, f.size)
            assert count == 0 and math.isclose(gam, want, rel_tol=1e-14)
            assert math.isclose(gam, gam_py, rel_tol=1e-10)
            assert np.allclose(xi, xi_py, atol=1e-6)


def test_the_gauge_bounds_under_linear_pressure_bracket_it(shim):
    """Linear pressure: max(gF, gT) <= gamma <= (P_c / p_min)(gF + gT), against face.py's
    gauge (its own minimisation), with p_min, the least of the pressure over the face's
    corners or rim, computed here apart; no upper bound where the pressure reaches 0."""
    mu, N = 0.4, 3.0
    seen = 0
    for f, mode, _ in _faces():
        if mode != "linear":
            continue
        c = np.asarray(f.centre)
        reach = np.asarray(f.half[:2]) if f.kind == "rectangle" else np.full(2, f.half[0])
        for off in ((0.0, 0.0), (0.3, -0.2), (0.9, 0.4), (2.0, 1.5)):
            cp = c + np.asarray(off) * reach / 8.0
            kind, geom, k = _face_args(f, N, cp, mode)
            if f.kind == "rectangle":
                rim = c + np.array([[sx * reach[0], sy * reach[1]] for sx in (-1, 1)
                                    for sy in (-1, 1)])
            else:
                th = np.linspace(0, 2 * np.pi, 4001)
                rim = c + reach[0] * np.column_stack([np.cos(th), np.sin(th)])
            P_c = N / f.area
            p_min = float(np.min(P_c + (rim - c) @ k))
            fr = fc.Friction(f, N, cp, mode, mu)
            lohi = np.zeros(3)
            for _ in range(6):
                W = RNG.normal(size=3) * np.array([1, 1, f.size])
                rbar = shim.shim_bounds(kind, _ptr(geom), N, _ptr(k), mu, _ptr(_arr(W)),
                                        _ptr(lohi))
                if p_min <= 0.0:
                    assert lohi[1] == np.inf
                    continue
                gF = np.hypot(W[0], W[1]) / (mu * N)
                gT = abs(W[2] - (c[0] * W[1] - c[1] * W[0])) / (mu * N * rbar)
                assert math.isclose(lohi[1], (gF + gT) * P_c / p_min, rel_tol=1e-6)
                gam_py, _ = fc.gauge(fr, W, f.size)
                assert lohi[0] <= gam_py * (1 + 1e-10) and gam_py <= lohi[1] * (1 + 1e-10)
                seen += 1
    assert seen >= 30


@pytest.mark.parametrize("half", [(0.1, 0.102), (0.102, 0.1)])
def test_the_margins_of_a_near_square_face_are_face_pys(shim, half):
    """A face whose sides are 2 % apart, either way round (the kern's length is the shorter
    one), and points whose distances to the two edges are 2 % apart, either way round (the
    edge margin is the nearer): both margins as derive/face.py has them."""
    f = fc.face_on("box", (*half, 0.05), (0.01, -0.01, 0), (0, 0, 1))
    kind, geom, _ = _face_args(f, 1.0, None, "uniform")
    a, b = f.half
    for mx, my in ((0.0098, 0.01), (0.01, 0.0098), (0.049, 0.05), (0.05, 0.049)):
        p = (f.centre[0] + a - mx, f.centre[1] - (b - my))
        assert shim.shim_edge(kind, _ptr(geom), *p) == pytest.approx(f.edge_margin(p),
                                                                    abs=1e-15)
        assert f.edge_margin(p) == pytest.approx(min(mx, my), abs=1e-15)
    for p in ((0.02, 0.01), (-0.005, 0.02)):
        k = _arr([0.0, 0.0])
        margin = shim.shim_kern(kind, _ptr(geom), *p, 2.5, _ptr(k))
        assert margin == pytest.approx(f.kern_margin(p), abs=1e-15)


def _spin_torque(f, N, mu, v, w):
    """The torque about the centroid of a translation v turning slowly (w size << |v|),
    uniform pressure, to first order in w: the slip's direction at r turns by w (r.v)/|v|^2
    across v, so T_c = -mu (N/A) (w/|v|) int ((r - c).v/|v|)^2 dA (the force's part is
    the translation's)."""
    Ix, Iy = f.second_moments
    u = np.asarray(v) / math.hypot(*v)
    return -mu * N / f.area * w / math.hypot(*v) * (Ix * u[0] ** 2 + Iy * u[1] ** 2)


def test_a_slip_is_a_translation_up_to_its_threshold_and_turns_past_it(shim):
    """The translation's rule, |w| size <= 1e-12 |v|, at 0.98 and 1.02 of its threshold, in
    crt_face_wrench and in crt_face_slip_set (read by crt_face_apply): below it the force
    is -mu N v/|v| at the centroid (no torque about it), above it the slow turn's torque
    about the centroid is the first-order closed form's (to 1 %: the product rule far
    off), its force the translation's; the direction of either in any of the plane's
    directions."""
    N, mu = 2.0, 0.5
    for shape, dims in (("box", (0.2, 0.1, 0.05)), ("cylinder", (0.1, 0.05))):
        f = fc.face_on(shape, dims, (0.01, -0.01, 0), (0, 0, 1))
        kind, geom, k = _face_args(f, N, None, "uniform")
        c = f.centre
        for th in (0.3, 2.0, 4.4):
            v = 0.7 * np.array([math.cos(th), math.sin(th)])
            for factor in (0.98, 1.02):
                tw = _arr([*v, factor * 1e-12 * 0.7 / f.size])
                W, D = c_wrench(shim, f, N, None, "uniform", mu, tw)
                Wa = np.zeros(3)
                Da = shim.shim_apply(kind, _ptr(geom), N, _ptr(k), mu, _ptr(tw), _ptr(Wa), 1)
                want = _spin_torque(f, N, mu, v, tw[2]) if factor > 1 else 0.0
                for got, d in ((W, D), (Wa, Da)):
                    assert np.allclose(got[:2], -mu * N * v / 0.7, rtol=1e-12, atol=0)
                    assert math.isclose(d, mu * N * 0.7, rel_tol=1e-12)
                    Tc = got[2] - (c[0] * got[1] - c[1] * got[0])
                    assert abs(Tc - want) <= 1e-2 * abs(_spin_torque(f, N, mu, v, tw[2])), \
                        (shape, th, factor, Tc, want)


def test_linear_pressure_along_one_axis_is_face_pys(shim):
    """Linear pressure whose slope is along one axis of the face (the centre of pressure on
    the centroid's horizontal or vertical: the other component of k exactly 0), about
    instant centres near and far: the wrench as derive/face.py has it, to 1e-12."""
    N, mu = 2.0, 0.5
    rng = np.random.default_rng(7)
    for shape, dims in (("box", (0.2, 0.1, 0.05)), ("cylinder", (0.1, 0.05))):
        f = fc.face_on(shape, dims, (0.01, -0.01, 0), (0, 0, 1))
        c = np.asarray(f.centre)
        for cp in (c + (0.012, 0.0), c + (0.0, -0.009)):
            assert np.count_nonzero(fc.pressure_slope(f, N, cp, "linear")[1]) == 1
            for reach in (0.5, 3.0, 11.0):         # the closed form or the disc's rule; far
                th = rng.uniform(0, 2 * np.pi)
                r0 = c + reach * f.size * np.array([math.cos(th), math.sin(th)])
                w = rng.choice([-1, 1]) * rng.uniform(0.5, 3)
                tw = (r0[1] * w, -r0[0] * w, w)
                W, D = c_wrench(shim, f, N, cp, "linear", mu, tw)
                py, D_py = fc.centre_wrench(f, N, cp, "linear", mu, tw)
                assert np.abs(W - py).max() <= 1e-12 * np.abs(py).max(), (shape, cp, reach)
                assert abs(D - D_py) <= 1e-12 * D_py


def test_the_gauge_bounds_parts_at_their_thresholds(shim):
    """crt_face_gauge_bounds on a face centred on O (T_c = T_z), its two parts gF = |F|/(mu
    N) and gT = |T_c|/(mu N rbar) computed here: the lower bound is the larger of two parts
    2 % apart (either way round), the upper their sum; and one part is taken for the whole
    (the closed form, part 1 or 2) at 0.98e-15 of the other, not at 1.02e-15."""
    mu, N = 0.4, 3.0
    F = np.array([0.6, -0.8])
    for shape, dims in (("box", (0.2, 0.1, 0.05)), ("cylinder", (0.1, 0.05))):
        f = fc.face_on(shape, dims, (0, 0, 0), (0, 0, 1))
        assert tuple(f.centre) == (0.0, 0.0)
        kind, geom, k = _face_args(f, N, None, "uniform")
        lohi = np.zeros(3)
        rbar = shim.shim_bounds(kind, _ptr(geom), N, _ptr(k), mu, _ptr(_arr([1.0, 0, 0])),
                                _ptr(lohi))
        gF = math.hypot(*F) / (mu * N)
        for ratio in (0.98, 1.02):
            W = _arr([*F, ratio * gF * mu * N * rbar])
            shim.shim_bounds(kind, _ptr(geom), N, _ptr(k), mu, _ptr(W), _ptr(lohi))
            gT = abs(W[2]) / (mu * N * rbar)
            assert math.isclose(lohi[0], max(gF, gT), rel_tol=1e-14), (shape, ratio)
            assert math.isclose(lohi[1], gF + gT, rel_tol=1e-14)
            assert lohi[2] == 0
        for ratio, part in ((0.98e-15, 1), (1.02e-15, 0)):
            W = _arr([*F, ratio * gF * mu * N * rbar])           # gT = ratio gF
            shim.shim_bounds(kind, _ptr(geom), N, _ptr(k), mu, _ptr(W), _ptr(lohi))
            assert lohi[2] == part, (shape, ratio)
            W = _arr([*(F / math.hypot(*F) * ratio * 0.05 / rbar), 0.05])
            shim.shim_bounds(kind, _ptr(geom), N, _ptr(k), mu, _ptr(W), _ptr(lohi))
            assert lohi[2] == 2 * part, (shape, ratio)          # gF = ratio gT


def test_the_gauge_of_a_long_thin_face_is_face_pys(shim):
    """A rectangle 25 times longer than wide, uniform and linear pressure: D's curvature on
    the plane W.xi = 1 is far from the search's first guess (isotropic), so its first
    steps overshoot and are cut back (Armijo's rule).  gamma as face.gauge has it (SciPy's
    BFGS on derive/face.py's friction) to 1e-10, the support property at xi*, and each
    search ends within 250 evaluations (where D no longer decreases: its round-off).  With
    random wrenches, three on which the search's steps overshoot (D up by less than 5 %)
    twice running (three of 400 random ones, found so: each a stall where Armijo's rule is
    loosened)."""
    mu, N = 0.4, 3.0
    f = fc.face_on("box", (0.3, 0.012, 0.05), (0.02, 0.0, 0), (0, 0, 1))
    rng = np.random.default_rng(1)
    counts = []
    for mode, cp, hard in (("uniform", None, [(0.745089, 2.12381, -0.504148),
                                              (-0.114717, -1.40132, -0.0105369)]),
                           ("linear", (0.08, -0.0012), [(0.548405, -1.06512, 0.548968)])):
        fr = fc.Friction(f, N, cp, mode, mu)
        for W in [*hard, *(rng.normal(size=3) * np.array([1, 1, f.size]) for _ in range(6))]:
            W = _arr(W)
            gam, xi, count = c_gauge(shim, f, N, cp, mode, mu, W)
            gam_py, _ = fc.gauge(fr, W, f.size)
            assert math.isclose(gam, gam_py, rel_tol=1e-10), (mode, W)
            fric, _ = c_wrench(shim, f, N, cp, mode, mu, xi * np.array([1.0, 1.0, 1.0 / f.size]))
            assert np.allclose(-fric * gam, W, rtol=0, atol=1e-7 * np.abs(W).max())
            counts.append(count)
    assert max(counts) <= 250, counts


def _angle_quadrature(f, N, cp, mode, mu, tw):
    """((F_x, F_y, T_z), D) of a disc by SciPy's adaptive quadrature over the angle about
    r0 (the radial integrals exact), written apart from face.py's rules and closed form:
    the range split where the chord's square root nearly vanishes (inside at theta = +-pi/2
    from r0 - c, outside, through sin(alpha) = (R/delta) sin(phi), at phi = +-pi/2), and at
    that root's width w and 10 w, 100 w from there."""
    R = f.half[0]
    P_c, k = fc.pressure_slope(f, N, cp, mode)
    w = tw[2]
    r0 = np.array([-tw[1] / w, tw[0] / w])
    d = r0 - np.asarray(f.centre)
    delta = math.hypot(*d)
    P0 = P_c + k @ d

    def parts(th, lo, hi, jac):
        ex, ey = math.cos(th), math.sin(th)
        ke = k[0] * ex + k[1] * ey
        m1 = P0 * (hi ** 2 - lo ** 2) / 2 + ke * (hi ** 3 - lo ** 3) / 3
        m2 = P0 * (hi ** 3 - lo ** 3) / 3 + ke * (hi ** 4 - lo ** 4) / 4
        return jac * np.array([ex * m1, ey * m1, (ex * r0[0] + ey * r0[1]) * m1 + m2, m2])
    thd = math.atan2(d[1], d[0])
    if delta < R:
        wid = math.sqrt((R - delta) * (R + delta)) / delta

        def at(x):
            de = delta * math.cos(x)
            return parts(thd + x, 0.0, -de + math.sqrt((R - delta) * (R + delta) + de * de), 1.0)
        marks = [a + s * m * wid for a in (math.pi / 2, 3 * math.pi / 2) for s in (-1, 1)
                 for m in (1, 10, 100)]
        edges = {0.0, 2 * math.pi, math.pi / 2, 3 * math.pi / 2,
                 *(x for x in marks if 0 < x < 2 * math.pi)}
    else:
        q = R / delta
        wid = math.sqrt((delta - R) * (delta + R)) / delta

        def at(ph):
            sn = q * math.sin(ph)
            ca = math.sqrt((1 - sn) * (1 + sn))
            root = R * math.cos(ph)
            return parts(thd + math.pi + math.asin(sn), delta * ca - root, delta * ca + root,
                         q * math.cos(ph) / ca)
        marks = [s * (math.pi / 2 - m * wid) for s in (-1, 1) for m in (1, 10, 100)]
        edges = {-math.pi / 2, 0.0, math.pi / 2, *(x for x in marks if abs(x) < math.pi / 2)}
    edges = sorted(edges)
    out = np.zeros(4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)     # roundoff, asked past it
        for a, b in zip(edges[:-1], edges[1:]):
            for j in range(4):
                out[j] += quad(lambda x, j=j: at(x)[j], a, b, limit=200, epsabs=1e-17,
                               epsrel=1e-13)[0]
    sg = 1.0 if w > 0 else -1.0
    return np.array([mu * sg * out[1], -mu * sg * out[0], -mu * sg * out[2]]), mu * abs(w) * out[3]


RIM_GAPS = (0.05, 1e-3, 1e-5, 1e-7, 1e-9, 0.0, -1e-6, -1e-3, -0.05)   # 1 - delta/R


def _rim_errors(shim, f, mode, cp, gap):
    """The C's and face.py's wrench and D off the angle's quadrature at delta = (1 - gap)
    R, on a random side of the centre: (C, Python), each the worst of the wrench over its
    largest component and of D over D."""
    N, mu = 2.0, 0.5
    R = f.half[0]
    th = RNG.uniform(0, 2 * math.pi)
    r0 = np.asarray(f.centre) + (1 - gap) * R * np.array([math.cos(th), math.sin(th)])
    w = RNG.choice([-1, 1]) * RNG.uniform(0.5, 3)
    tw = (r0[1] * w, -r0[0] * w, w)
    ref, D_ref = _angle_quadrature(f, N, cp, mode, mu, tw)
    scale = np.abs(ref).max()
    out = []
    for W, D in (c_wrench(shim, f, N, cp, mode, mu, tw), fc.centre_wrench(f, N, cp, mode, mu, tw)):
        out.append(max(np.abs(W - ref).max() / scale, abs(D - D_ref) / D_ref))
    return out


def test_a_discs_wrench_near_its_rim_is_scipys_quadrature(shim):
    """The instant centre within 0.05 R of a disc's rim, inside and out (and on it): the
    closed form (complete elliptic integrals) in C (the arithmetic-geometric mean) and in
    face.py (SciPy's ellipe, ellipkm1) against SciPy's adaptive quadrature over the angle,
    uniform and linear pressure, to 1e-12 of the wrench's scale (2.2e-15 at most measured;
    the trapezoid rule they replace was 9.7e-8 off at 1e-7 R inside the rim)."""
    for f, mode, cp in _faces():
        if f.kind != "disc":
            continue
        for gap in RIM_GAPS:
            err_c, err_py = _rim_errors(shim, f, mode, cp, gap)
            assert err_c <= 1e-12 and err_py <= 1e-12, (mode, gap, err_c, err_py)


def test_the_rim_test_sees_the_rule_it_replaced(shim, monkeypatch):
    """The check above can fail: face.py with its closed form's band emptied (RIM = 1: the
    trapezoid rule up to the rim) is 1e-9 off at least at 1e-5 R inside the rim."""
    f = next(f for f, mode, _ in _faces() if f.kind == "disc" and mode == "uniform")
    monkeypatch.setattr(fc, "RIM", 1.0)
    _, err_py = _rim_errors(shim, f, "uniform", None, 1e-5)
    assert err_py > 1e-9, err_py


def test_a_discs_moments_are_continuous_across_the_rims_band(shim):
    """At the band's ends (CRT_FACE_RIM R and R / CRT_FACE_RIM, face.RIM) the rules on one
    side and the closed form on the other agree to round-off, and on the rim the closed
    form's inside and outside (1e-14 of the wrench's scale; 1.3e-15 at most measured), in
    C and in face.py."""
    N, mu = 2.0, 0.5
    for f, mode, cp in _faces():
        if f.kind != "disc":
            continue
        R = f.half[0]
        for edge in (fc.RIM * R, R, R / fc.RIM):     # at R: the inside form, the outside
            sides = []
            for eps in (-2e-16, 2e-16):          # the rule, then the closed form
                r0 = np.asarray(f.centre) + edge * (1 + eps) * np.array([0.6, -0.8])
                delta = math.hypot(*(r0 - np.asarray(f.centre)))
                assert (delta < edge) == (eps < 0) and (delta > edge) == (eps > 0)
                tw = (r0[1] * 1.5, -r0[0] * 1.5, 1.5)
                sides.append((c_wrench(shim, f, N, cp, mode, mu, tw),
                              fc.centre_wrench(f, N, cp, mode, mu, tw)))
            for (Wa, Da), (Wb, Db) in zip(*sides):
                assert np.abs(Wa - Wb).max() <= 1e-14 * np.abs(Wa).max(), (mode, edge)
                assert abs(Da - Db) <= 1e-14 * Da

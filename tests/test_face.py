"""derive/face.py: the face a body rests on and the friction over it, against closed forms
and against the reference integrator's own integrals (adaptive quadrature,
derive/base_reference.py).

* A box's six faces and a cylinder's two ends: the frame turns n to e_z, and the face's
  centre and O's height are the registry's lowest point S (derive/shapes.py, sign 0 at a
  face's middle).
* Closed forms: a translation (F = -mu N v/|v|, exact for every rule); pure spin about the
  centre of a disc (T = -(2/3) mu N R, exact for both rules) and of a rectangle (T = -mu
  N/(4ab) int |r| dA, int over [0,a]x[0,b] of |r| = (2ab d + a^3 ln((b+d)/a) + b^3
  ln((a+d)/b))/6); linear pressure vanishing at a corner where cp reaches the kern.
* The instant-centre rule (the C design: a rectangle in closed form edge by edge, a disc
  by 32-point rules about r0) against the reference's adaptive quadrature on random
  twists, instant centres anywhere within 12 face sizes: 1e-13.  The product rule n x n
  (the simple alternative) is measured: with the instant centre on the face its cone
  point costs it digits (worst 6e-2 of the largest component at n = 12, 3e-2 at n = 24
  on these twists).
* The limit surface's gauge: |F|/(mu N) for a force through the pressure centre,
  |T|/((2/3) mu N R) for a torque on a disc, the face rule's and the reference's gauges
  equal to 1e-9 on random wrenches, and the wrench at the gauge's twist is the slip's
  friction (the support property).
"""
import math

import numpy as np
import pytest

from derive import base_reference as br
from derive import face as fc
from derive import shapes

RNG = np.random.default_rng(11)


@pytest.mark.parametrize("shape, size, normals", [
    ("box", (0.2, 0.1, 0.05), [s * e for e in np.eye(3) for s in (1, -1)]),
    ("cylinder", (0.1, 0.07), [np.array([0, 0, 1.0]), np.array([0, 0, -1.0])])])
def test_each_face_is_under_the_registrys_lowest_point(shape, size, normals):
    center = (0.01, -0.02, 0.03)
    for n in normals:
        f = fc.face_on(shape, size, center, n)
        Q = f.frame
        assert np.allclose(Q @ Q.T, np.eye(3)) and np.isclose(np.linalg.det(Q), 1.0)
        assert np.allclose(Q @ n, [0, 0, 1])
        S = Q @ np.array(shapes.of(shape).lowest(n, center, size))
        assert np.allclose(S, [*f.centre, -f.height], rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="along no face normal"):
        fc.face_on(shape, size, center, (0.1, 0.0, 1.0))


def _systems():
    box = fc.face_on("box", (0.2, 0.1, 0.05), (0.01, -0.01, 0), (0, 0, 1))
    disc = fc.face_on("cylinder", (0.1, 0.05), (0.01, -0.01, 0), (0, 0, 1))
    for f in (box, disc):
        for mode, cp in (("uniform", None), ("linear", (0.015, -0.005))):
            yield f, mode, cp


def test_translation_and_pure_spin_are_the_closed_forms():
    mu, N = 0.5, 2.0
    for f, mode, cp in _systems():
        for rule in (dict(product=True, n=12), dict(n=32)):
            fr = fc.Friction(f, N, cp, mode, mu, **rule)
            W, D = fr((0.3, -0.4, 0.0))
            centre = np.asarray(cp if cp else f.centre)
            F = -mu * N * np.array([0.6, -0.8])
            assert np.allclose(W, [*F, centre[0] * F[1] - centre[1] * F[0]], atol=1e-14)
            assert math.isclose(D, mu * N * 0.5, rel_tol=1e-14)
    disc = fc.face_on("cylinder", (0.1, 0.05), (0, 0, 0), (0, 0, 1))
    for rule in (dict(product=True, n=8), dict(n=32)):
        W, D = fc.Friction(disc, N, None, "uniform", mu, **rule)((0.0, 0.0, 3.0))
        assert math.isclose(W[2], -2 / 3 * mu * N * 0.1, rel_tol=1e-14)
        assert math.isclose(D, 3.0 * 2 / 3 * mu * N * 0.1, rel_tol=1e-14)
    a, b = 0.2, 0.1
    d = math.hypot(a, b)
    quarter = (2 * a * b * d + a ** 3 * math.log((b + d) / a) + b ** 3 * math.log((a + d) / b)) / 6
    box = fc.face_on("box", (a, b, 0.05), (0, 0, 0), (0, 0, 1))
    W, D = fc.centre_wrench(box, N, None, "uniform", mu, (0.0, 0.0, -2.0))
    assert math.isclose(W[2], mu * N / (4 * a * b) * 4 * quarter, rel_tol=1e-14)
    assert abs(W[0]) < 1e-15 and abs(W[1]) < 1e-15


def test_linear_pressure_vanishes_at_a_corner_when_cp_reaches_the_kern():
    box = fc.face_on("box", (0.2, 0.1, 0.05), (0.01, 0, 0), (0, 0, 1))
    cp = (0.01 + 0.2 / 3 * 0.4, 0.1 / 3 * 0.6)          # |x|/a + |y|/b = 1/3
    assert abs(box.kern_margin(cp)) < 1e-15
    P, k = fc.pressure_slope(box, 2.0, cp, "linear")
    corner = np.array([-0.2, -0.1])                    # from the face's centre
    assert abs(P + k @ corner) < 1e-13 and min(P + k @ c for c in
                                                 ([0.2, 0.1], [-0.2, 0.1], [0.2, -0.1])) > 0
    disc = fc.face_on("cylinder", (0.1, 0.05), (0, 0, 0), (0, 0, 1))
    cp = (0.025 * 0.6, 0.025 * 0.8)
    P, k = fc.pressure_slope(disc, 2.0, cp, "linear")
    assert abs(disc.kern_margin(cp)) < 1e-16 and abs(P - 0.1 * np.linalg.norm(k)) < 1e-12


def _twists(f, count):
    for _ in range(count):
        r0 = np.asarray(f.centre) + RNG.uniform(-12, 12, 2) * f.size * RNG.uniform(0, 1) ** 2
        w = RNG.choice([-1, 1]) * RNG.uniform(0.5, 3)
        yield (r0[1] * w, -r0[0] * w, w)          # the twist turning about r0


def test_the_instant_centre_rule_is_the_reference_and_the_product_rule_measured():
    worst = {12: 0.0, 24: 0.0}
    for f, mode, cp in _systems():
        system = br.System(M=1, J=(1, 1, 1), face=f, pressure=mode)
        for tw in _twists(f, 40):
            ref, D_ref = br.friction(system, 0.5, 2.0, cp, tw)
            W, D = fc.centre_wrench(f, 2.0, cp, mode, 0.5, tw)
            scale = np.abs(ref).max()
            assert np.abs(W - ref).max() <= 1e-13 * scale and abs(D - D_ref) <= 1e-13 * D_ref
            for n in worst:
                Wp, _ = fc.Friction(f, 2.0, cp, mode, 0.5, n, product=True)(tw)
                worst[n] = max(worst[n], np.abs(Wp - ref).max() / scale)
    assert 1e-4 < worst[12] < 0.1 and worst[24] < worst[12]


def test_the_limit_surface_gauge():
    mu, N = 0.4, 3.0
    box = fc.face_on("box", (0.2, 0.1, 0.05), (0, 0, 0), (0, 0, 1))
    fr = fc.Friction(box, N, None, "uniform", mu)
    gam, xi = fc.gauge(fr, (0.5, -0.3, 0.0), box.size)
    assert math.isclose(gam, math.hypot(0.5, 0.3) / (mu * N), rel_tol=1e-12)
    assert np.allclose(xi, [0.5, -0.3, 0] / np.float64(math.hypot(0.5, 0.3)), atol=1e-9)
    disc = fc.face_on("cylinder", (0.1, 0.05), (0, 0, 0), (0, 0, 1))
    gam, _ = fc.gauge(fc.Friction(disc, N, None, "uniform", mu), (0, 0, 0.05), disc.size)
    assert math.isclose(gam, 0.05 / (2 / 3 * mu * N * 0.1), rel_tol=1e-12)
    for f, mode, cp in _systems():
        system = br.System(M=1, J=(1, 1, 1), face=f, pressure=mode, mu=mu)
        fr = fc.Friction(f, N, cp, mode, mu)
        for _ in range(4):
            W = RNG.normal(size=3) * np.array([1, 1, f.size])
            gam, xi = fc.gauge(fr, W, f.size)
            gam_ref, _ = br.limit_gauge(system, N, cp, W)
            assert math.isclose(gam, gam_ref, rel_tol=1e-9)
            # the support property: at xi* the slip's friction is -W/gamma
            fric, _ = fr(xi * np.array([1.0, 1.0, 1.0 / f.size]))
            assert np.allclose(-fric * gam, W, rtol=0, atol=1e-7 * np.abs(W).max())

"""A slender rod striking a rough plane with its end (Stronge, Impact Mechanics, 2000,
ch. 5; qualitatively), through the derived functions and derive/darboux_keller.py.

The carrier is a rod of half-length L (J_x = J_y = (m+M) L^2/3 about its centre, a small
J_z), the point sits at its centre, the rod's lower end S is at L along the body z axis,
which is inclined at theta below the horizontal, in the fixed X-Z plane, the end on the
+X side of C.  From the rod's own impulse equations (independent of the derivation):

  W_XX = 1/(m+M) + L^2 sin^2(theta)/J_r,  W_ZZ = 1/(m+M) + L^2 cos^2(theta)/J_r,
  W_XZ = L^2 sin(theta) cos(theta)/J_r > 0      (a normal impulse pushes the end outwards)

What the literature says and the checks below see:

* falling without spin or slip, the end sticks at once iff mu_f >= W_XZ/W_XX
  = 3 sin cos/(1 + 3 sin^2) (J_r = (m+M) L^2/3); otherwise it slides outwards (+X) for
  the whole impact, the normal velocity is linear in p and the three restitution models
  give the same impulse;
* sliding inwards at first, the slip stops during the impact and then sticks (mu_f at
  or above the critical value) or reverses (below it);
* Newton's law v_n+ = -e v_n- makes some of these impacts gain energy (Kane and
  Levinson's paradox, Stronge 1990), which is why derive/darboux_keller.py refuses it
  where mu_f |W_tn| != 0; the energetic law never gains energy.
"""
from __future__ import annotations

import numpy as np
import pytest

from derive import darboux_keller as dk
from derive.emit.numpy_backend import numpy_function

L = 0.5
MASS = 1.0                 # m + M
J_R = MASS * L * L / 3.0


def rod(theta, v_X=0.0, v_Z=-1.0):
    s_, c_ = np.sin(theta), np.cos(theta)
    A = np.array([[s_, 0.0, c_], [0.0, -1.0, 0.0], [c_, 0.0, -s_]])   # body z -> (c, 0, -s)
    assert np.linalg.det(A) == pytest.approx(1.0)
    q = np.concatenate([[0.0, 0.0, L * s_], [v_X, 0.0, v_Z], np.zeros(3), A.ravel()])
    params = np.array([0.98 * MASS, 0.02 * MASS, J_R, J_R, 1e-3 * J_R, 9.81])
    return q, np.zeros(9), np.array([0.0, 0.0, L]), params


def test_the_rods_delassus_matrix():
    for theta in np.linspace(0.1, 1.4, 9):
        q, u, s, params = rod(theta)
        w6, v = numpy_function("general_delassus")(q, u, s, params)
        W = dk.full(w6)
        sn, cs = np.sin(theta), np.cos(theta)
        assert W[0, 0] == pytest.approx(1 / MASS + L * L * sn * sn / J_R, rel=1e-12)
        assert W[2, 2] == pytest.approx(1 / MASS + L * L * cs * cs / J_R, rel=1e-12)
        assert W[0, 2] == pytest.approx(L * L * sn * cs / J_R, rel=1e-12)
        assert abs(W[0, 1]) < 1e-14 and abs(W[1, 2]) < 1e-14
        assert v == pytest.approx([0.0, 0.0, -1.0])


@pytest.mark.parametrize("theta", [0.2, 0.5, 0.8, 1.1])
def test_falling_rod_sticks_iff_mu_is_above_critical(theta):
    critical = 3 * np.sin(theta) * np.cos(theta) / (1 + 3 * np.sin(theta) ** 2)
    q, u, s, params = rod(theta)
    for mu in (0.5 * critical, 0.95 * critical, 1.05 * critical, 2.0 * critical):
        res = {m: dk.impact(q, u, s, params, mu, 0.7, m)
               for m in ("energetic", "poisson")}
        kinds = [k for _, k in res["energetic"].events]
        if mu >= critical:
            assert kinds[0] == "stick" and abs(res["energetic"].v_plus[0]) < 1e-12
        else:
            assert kinds[0] == "re-slide"
            assert res["energetic"].v_plus[0] > 0.0                 # outwards
            assert res["energetic"].impulse[0] == pytest.approx(
                -mu * res["energetic"].impulse[2], rel=1e-12)
        # slip in one direction or stick from p = 0: v_n linear in p, same impulse
        assert res["poisson"].impulse == pytest.approx(res["energetic"].impulse, rel=1e-10)


def test_inward_slip_stops_then_sticks_or_reverses():
    theta = 0.6
    critical = 3 * np.sin(theta) * np.cos(theta) / (1 + 3 * np.sin(theta) ** 2)
    for mu, then in ((0.6 * critical, "re-slide"), (1.3 * critical, "stick")):
        q, u, s, params = rod(theta, v_X=-0.3)
        res = dk.impact(q, u, s, params, mu, 0.8)
        kinds = [k for _, k in res.events]
        assert kinds[0] == "slip stops" and kinds[1] == then, kinds
        if then == "re-slide":
            assert res.v_plus[0] > 0.0          # the slip has turned outwards
        else:
            assert res.v_plus[0] == 0.0
        assert res.work_normal <= 0.0 and res.work_friction <= 0.0


def test_newtons_law_gains_energy_on_the_rod_and_is_refused():
    """Over a grid of angles, slips and restitutions, Newton's law (forced with
    strict=False) gains energy in some impacts, all of them with the slip stopping;
    the energetic law never does; the default refuses Newton's law here."""
    gains, worst_energetic = [], -np.inf
    for theta in np.linspace(0.1, 1.4, 8):
        for ratio in np.linspace(-2.0, 1.0, 7):
            for mu in (0.3, 0.6, 0.9):
                for e in (0.5, 1.0):
                    q, u, s, params = rod(theta, v_X=ratio)
                    res = dk.impact(q, u, s, params, mu, e, "newton", strict=False)
                    if res.work_normal + res.work_friction > 1e-12:
                        gains.append([k for _, k in res.events])
                    en = dk.impact(q, u, s, params, mu, e)
                    worst_energetic = max(worst_energetic, en.work_normal + en.work_friction)
    assert gains and all("stick" in k or "re-slide" in k for k in gains)
    assert worst_energetic <= 0.0
    q, u, s, params = rod(0.7, v_X=-0.5)
    with pytest.raises(ValueError, match="newton"):
        dk.impact(q, u, s, params, 0.5, 0.9, "newton")

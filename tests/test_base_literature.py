"""The capsule robots of the literature, reproduced by the base model's reference
integrator (derive/base_reference.py); these become the acceptance checks of its C
runtime.

* Bardin and Panev (Rus. J. Nonlin. Dyn. 14(4), 2018): a point on a vertical circle
  about O at a constant rate; a periodic mode always exists, of one of three types by the
  parameters.  The three appear as mu grows (two reversals a period and no rest; one rest
  and one reversal; two rests), and every stop agrees with the 1-D Coulomb model of
  tests/test_friction_couples.py to 1e-8.  The same body run by today's runtime with its
  stand-in (a sphere whose rolling resistance and spin friction hold it like a flat foot)
  stops at the same times to 1e-8 (the full rough model where both apply).
* The fastest crawl of derive/capsule.py (a velocity jump, a slide, a ramp at kappa times
  the sticking limit): the mean speed of three laws at one range against the closed
  form to 1e-9, the best at u2/w = 1/(2 (1 + kappa)).
"""
import math

import numpy as np
import pytest

from derive import base_reference as br
from derive import capsule
from derive import face as fc
from test_friction_couples import MODES_OF_MOTION, _coulomb_1d, _foot

M, m, r, w = 1.0, 0.3, 0.05, 20.0      # the setting of test_friction_couples
PERIOD = 2 * math.pi / w


def circle(t):
    c, s = math.cos(w * t), math.sin(w * t)
    return (np.array([r * c, 0.0, r * s]), np.array([-r * w * s, 0.0, r * w * c]),
            np.array([-r * w * w * c, 0.0, -r * w * w * s]))


def _system(mu):
    face = fc.face_on("box", (0.1, 0.05, 0.03), (0, 0, 0), (0, 0, 1))
    return br.System(M=M, J=(0.01, 0.02, 0.02), face=face, points=(br.Point(m, circle),),
                     mu=mu)


@pytest.mark.parametrize("mu", sorted(MODES_OF_MOTION))
def test_bardin_and_panevs_three_mode_types(mu):
    duration = 2.5 if "stick" not in MODES_OF_MOTION[mu] else 1.0
    run = br.Integrator(_system(mu)).run(np.zeros(6), 0.0, duration)
    assert run.status == "done"
    tail = sorted(((t % PERIOD) / PERIOD, k) for t, k in run.events if t > duration - PERIOD)
    assert sorted(k for _, k in tail) == sorted(MODES_OF_MOTION[mu])
    _, stops = _coulomb_1d(M, m, r, w, mu, 0.0, 0.0, duration)
    ends = [t for t, k in run.events if k in ("stick", "reversal")]
    assert len(ends) == len(stops) and np.abs(np.array(ends) - stops).max() < 1e-8


def test_the_runtimes_flat_foot_stand_in_stops_when_the_base_model_does():
    from derive import simulate
    doc, (_, _, _, _, mu) = _foot(0.1, mu=0.3, duration=1.0)
    res = simulate(doc)
    assert res.status == "done"
    t0 = max(e["t"] for e in res.events if e["kind"] in ("roll_stop", "contact"))
    i0 = int(np.searchsorted(res.t, t0, side="right"))
    u0 = res.q[i0 - 1, 3] - m / (M + m) * (-r * w * math.sin(w * res.t[i0 - 1]))   # O's
    run = br.Integrator(_system(mu)).run([0, 0, 0, u0, 0, 0], res.t[i0 - 1], res.t[-1])
    ours = [t for t, k in run.events if k in ("stick", "reversal")]
    theirs = [e["t"] for e in res.events if e["kind"] in ("stick", "reversal") and e["t"] > t0]
    assert len(ours) == len(theirs) >= 4
    assert np.abs(np.array(ours) - theirs).max() < 1e-8


def test_the_fastest_crawl_of_its_class_goes_at_the_closed_form_speed():
    Mb, mp, mu, L, kappa = 1.0, 0.5, 0.3, 0.04, 0.9
    face = fc.face_on("box", (0.08, 0.05, 0.03), (0, 0, 0), (0, 0, 1))
    rk = 1 / (2 * (1 + kappa))
    speeds = {}
    for share in (rk - 0.05, rk, rk + 0.05):
        law = capsule.crawl(Mb, mp, mu, L, share, kappa)
        # periodic, x' crossing 0 once up (its least x) and at the jump (its largest)
        assert abs(law.law(law.period * (1 - 1e-15))[0]) < 1e-14
        lowest = law.law(law.tau + law.t5 + law.u2 / law.a)[0]
        assert abs(-lowest - L) < 1e-15 and law.law(law.period / 3)[0] > lowest
        point = br.Point(mp, lambda t, law=law: (np.array([law.law(t)[0], 0.0, 0.0]),
                                                np.array([law.law(t)[1], 0.0, 0.0]),
                                                np.array([law.law(t)[2], 0.0, 0.0])))
        periods = 2
        marks = sorted(k * law.period + p for k in range(periods) for p in law.phases)
        system = br.System(M=Mb, J=(0.01, 0.01, 0.01), face=face, points=(point,), mu=mu,
                           jumps=tuple(k * law.period for k in range(1, periods + 1)))
        v0 = law.nu * (law.u1 + law.u2)            # just after the jump, from rest
        run = br.Integrator(system).run([0, 0, 0, v0, 0, 0], 0.0,
                                        periods * law.period * (1 - 1e-12), samples=marks)
        assert run.status == "done"
        kinds = [k for _, k in run.events]
        assert kinds.count("stick") == periods and "reversal" not in kinds
        X = run.samples[-1][1]
        speed = X / (periods * law.period * (1 - 1e-12))
        assert abs(speed - law.speed) < 1e-9 * law.speed
        speeds[share] = speed
    assert speeds[rk] > max(speeds[rk - 0.05], speeds[rk + 0.05])
    best = capsule.crawl(Mb, mp, mu, L, rk, kappa).speed
    assert abs(best - kappa / (2 * kappa + 1) * math.sqrt(2 * kappa * mp / (Mb + mp) * mu
                                                          * 9.81 * L)) < 1e-15
    assert capsule.optimum(Mb, mp, mu, L=L) > best

"""Energy in frictional impacts (derive/darboux_keller.py), and the integration itself
against plain time-stepping.

* Under the energetic law the work of the normal impulse is ``(1 - e^2) E_c <= 0`` and
  friction's ``E_t = int (v_t, dP_t) = -mu_f int |v_t| dp <= 0``: an impact never gains
  energy.  The two bodies' kinetic energy (tests/newton_euler_friction.py, from their
  velocities) changes by exactly that work plus the drive's, ``Pi . V_r`` (the point's
  prescribed relative velocity does not jump, so its drive works against the impulse
  ``Pi`` it transmits): a balance between the integrated path and the state update.
* The event-driven integration agrees with first-order time-stepping in ``p`` that
  treats slip, stick and re-sliding in each step by Coulomb's cone (no events).

The reference integrator's sweep takes a hundred random states; thousands go through the
runtime's own impact (crt_eval_impact), which is held to the reference elsewhere.
"""
from __future__ import annotations

import numpy as np
import pytest

import newton_euler_friction as ne
from cases import cases
from derive import darboux_keller as dk
from derive.emit.numpy_backend import numpy_function


def _approaching(c, rng):
    q = c.q_general.copy()
    (v,) = numpy_function("general_contact_velocity")(q, c.u, c.s, c.p)
    q[5] -= v[2] + rng.uniform(0.1, 3.0)          # S moves down at 0.1 to 3 m/s
    return q


def _energy_sweep(n, seed, restitutions=("energetic",)):
    rng = np.random.default_rng(seed)
    seen = {}
    for c in cases(n, seed=seed):
        q = _approaching(c, rng)
        mu, e = rng.uniform(0.0, 2.0), rng.uniform(0.0, 1.0)
        for restitution in restitutions:
            try:
                res = dk.impact(q, c.u, c.s, c.p, mu, e, restitution)
            except dk.ImpactJam:
                seen["jam"] = seen.get("jam", 0) + 1
                continue
            scale = float(np.abs(res.v_minus).max() ** 2 / res.W[2, 2])
            work = res.work_normal + res.work_friction
            assert res.work_friction <= 1e-12 * scale
            if restitution == "energetic":
                assert res.work_normal <= 1e-12 * scale
            elif work > 1e-12 * scale:
                seen["poisson gains"] = seen.get("poisson gains", 0) + 1
            T0 = ne.kinetic_energy(q, c.u, c.p)
            T1 = ne.kinetic_energy(res.q_plus, c.u, c.p)
            drive = ne.drive_work(q, c.u, c.s, c.p, res.impulse)
            assert T1 - T0 - drive == pytest.approx(work, abs=1e-10 * max(T0, scale))
            kind = next((k for _, k in res.events if k in ("stick", "re-slide")), "slip")
            seen[kind] = seen.get(kind, 0) + 1
    return seen


def test_energetic_impacts_never_gain_energy():
    seen = _energy_sweep(100, 11)
    assert seen.get("slip", 0) and seen.get("stick", 0), seen


def test_without_a_drive_the_kinetic_energy_never_grows():
    """V_r = 0: the balance is the contact impulse's work alone, <= 0."""
    rng = np.random.default_rng(13)
    for c in cases(40, seed=13):
        c.v = np.zeros(3)
        q = _approaching(c, rng)
        res = dk.impact(q, c.u, c.s, c.p, rng.uniform(0.0, 2.0), rng.uniform(0.0, 1.0))
        T0, T1 = ne.kinetic_energy(q, c.u, c.p), ne.kinetic_energy(res.q_plus, c.u, c.p)
        assert ne.drive_work(q, c.u, c.s, c.p, res.impulse) == 0.0
        assert T1 - T0 <= 1e-12 * T0


def test_energy_sweep_thousands_through_the_runtime():
    """The same balance over 3000 random states under both laws, through the impact the
    runtime runs (crt_eval_impact, the C Darboux-Keller integration that
    tests/test_friction_runtime.py holds to the reference integrator above): the works
    it reports are never positive (energetic: the normal impulse's too), and the two
    bodies' kinetic energy after its impulse (derive/friction_models.py's impulse map)
    changes by exactly those works plus the drive's.  Slip, stick and re-sliding all
    occur (the reference integrator's sweep of these thousands took a minute)."""
    from derive import abi
    from derive.runtime.build import library
    from derive.runtime.driver import prepare
    from derive.runtime.session import Session
    prep = prepare({"body": {"mass": 1.0, "inertia": [0.004] * 3, "shape": "sphere",
                             "radius": 0.1},
                    "point": {"mass": 0.2, "law": ["0", "0", "0"]},
                    "plane": {"restitution": 0.5, "friction": 0.3},
                    "initial": {"com": [0.0, 0.0, 0.5]}, "run": {"duration": 1.0}})
    assert prep.kind == "rough"
    session = Session(library("rough"), chunk=16)
    session.set_law(prep.scene.law)
    delassus = numpy_function("general_delassus")
    apply_impulse = numpy_function("general_apply_impulse")
    rng = np.random.default_rng(17)
    seen: dict = {}
    for c in cases(3000, seed=17):
        q = _approaching(c, rng)
        w6, v0 = delassus(q, c.u, c.s, c.p)
        mu, e = rng.uniform(0.0, 2.0), rng.uniform(0.0, 1.0)
        for law, restitution in enumerate(("energetic", "poisson")):
            prm = prep.parameters.copy()
            prm[abi.PRM["friction"]], prm[abi.PRM["e"]] = mu, e
            prm[abi.PRM["restitution_model"]] = law
            session.init(prep.options, prm, prep.scene.t0, prep.start.q0)
            status, out = session.impact(dk.full(w6), v0)
            if status == "painleve":
                seen["jam"] = seen.get("jam", 0) + 1
                continue
            assert status == "ok", status
            scale = float(np.abs(v0).max() ** 2 / w6[5])
            work = out["work_normal"] + out["work_friction"]
            assert out["work_friction"] <= 1e-12 * scale
            if restitution == "energetic":
                assert out["work_normal"] <= 1e-12 * scale
            (q_plus,) = apply_impulse(q, c.u, c.s, c.p, out["impulse"])
            T0 = ne.kinetic_energy(q, c.u, c.p)
            T1 = ne.kinetic_energy(q_plus, c.u, c.p)
            drive = ne.drive_work(q, c.u, c.s, c.p, out["impulse"])
            assert T1 - T0 - drive == pytest.approx(work, abs=1e-9 * max(T0, scale))
            kind = ("slip", "stick", "re-slide")[out["stage"]]
            seen[kind] = seen.get(kind, 0) + 1
    print(seen)
    assert seen.get("slip", 0) and seen.get("stick", 0) and seen.get("re-slide", 0), seen


def _step_cases(n, seed):
    """(W, v0, mu, e): random states, and from each W two cases that start without slip,
    one just inside the stick cone and one outside (stick at once, re-slide at once)."""
    rng = np.random.default_rng(seed)
    out = []
    for c in cases(n, seed=seed):
        q = _approaching(c, rng)
        w6, v0 = numpy_function("general_delassus")(q, c.u, c.s, c.p)
        W = dk.full(w6)
        out.append((W, v0, rng.uniform(0.0, 1.5), rng.uniform(0.0, 1.0)))
        tau, _ = ne.stick_rate(W)
        for f in (1.2, 0.6):
            out.append((W, np.r_[0.0, 0.0, v0[2]], f * np.linalg.norm(tau),
                        rng.uniform(0.0, 1.0)))
    return out


def test_events_agree_with_time_stepping():
    kinds = set()
    for W, v0, mu, e in _step_cases(4, 29):
        res = dk.integrate(W, v0, mu, e)
        if res.impulse[2] > 20.0 * abs(v0[2]) / W[2, 2]:
            continue                               # a near-jam: too many small steps
        P, v = ne.impact_by_small_steps(W, v0, mu, e, 2000)
        scale = np.abs(res.impulse).max()
        assert np.abs(P - res.impulse).max() < 3e-3 * scale
        assert np.abs(v - res.v_plus).max() < 3e-3 * np.abs(v0).max()
        kinds.add(next((k for _, k in res.events if k in ("stick", "re-slide")), "slip"))
    assert kinds == {"slip", "stick", "re-slide"}, kinds

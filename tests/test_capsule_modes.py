"""Capsule studies (issue 33 item 5): Bardin and Panev's periodic modes found by the base
model's C runtime, the stand-in of a flat foot against the base model, and the sweep of
the mean speed against friction and frequency.

* Bardin and Panev (Rus. J. Nonlin. Dyn. 14(4), 2018): derive/scene/examples/
  bardin-panev.toml over cells of (mu, beta), classified by derive.runtime.modes, against
  a 1-D Coulomb model written here in closed form (the slip's velocity is an explicit
  function of t; its zeros and the rest's end are found by bracketing and Brent's
  method): the type, and every stop of 40 periods to 1e-8 s (measured: 3e-11 s).  The
  rest's boundary beta = mu/sqrt(1 + mu^2) on both sides.  Two cells where the runtime
  misses a stop, as strict xfails.
* The flat-foot stand-in (a sphere with rolling resistance and spin friction, the rough
  model) against the base model on the 1-D capsule of capsule-crawler.toml.
* ``--sweep 'point.law[0]=... for W=...'`` and the column mean_speed, against the 1-D
  stick-slip closed form of tests/test_base_closed_forms.py.
"""
from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import derive
from derive.cli import main
from derive.runtime import choice, modes

ROOT = Path(__file__).parents[1]
CRAWLER = ROOT / "derive" / "scene" / "examples" / "capsule-crawler.toml"


# ---- a 1-D Coulomb model in closed form ---------------------------------------------------
class Coulomb1D:
    """The body along the plane, O's velocity u: (M + m) u' = F + m r w^2 cos(w t), N =
    (M + m) g - m r w^2 sin(w t), F = -mu N sign(u) in a slip, the rest held while
    |m r w^2 cos(w t)| <= mu N.  With a = m r w/(M + m), a slip of sign s from (t0, 0):
    u(t) = a (sin w t - sin w t0) - mu s (g (t - t0) + a (cos w t - cos w t0))."""

    def __init__(self, M, m, r, w, mu, g):
        self.a, self.w, self.mu, self.g = m * r * w / (M + m), w, mu, g

    def u(self, t, t0, s):
        a, w = self.a, self.w
        return a * (np.sin(w * t) - np.sin(w * t0)) - self.mu * s * (
            self.g * (t - t0) + a * (np.cos(w * t) - np.cos(w * t0)))

    def cone(self, t):
        """>= 0 where the rest holds."""
        a, w = self.a, self.w
        return self.mu * (self.g - a * w * np.sin(w * t)) - np.abs(a * w * np.cos(w * t))

    def _first(self, f, t0, t_end):
        """The first zero of f after t0 where it turns <= 0 (None before t_end)."""
        span = 2 * math.pi / self.w
        lo = t0
        while lo < t_end:
            grid = np.linspace(lo, min(lo + span, t_end), 4001)
            v = f(grid)
            k = np.flatnonzero(v[1:] <= 0.0)
            if len(k):
                i = k[0] + 1
                if v[i] == 0.0:
                    return float(grid[i])
                return brentq(f, grid[i - 1], grid[i], xtol=1e-15, rtol=1e-15)
            lo = grid[-1]
        return None

    def run(self, t_end):
        """The events (t, kind) from rest at t = 0: slip, stick, reversal."""
        t, events = 0.0, []
        resting = True
        while t < t_end:
            if resting:
                if self.cone(t) > 0.0:
                    t_b = self._first(self.cone, t, t_end)
                    if t_b is None:
                        return events
                    t = t_b
                events.append((t, "slip"))
                s = math.copysign(1.0, math.cos(self.w * t))
                resting = False
            t0 = t
            h = 1e-9 * 2 * math.pi / self.w          # past the start's own zero
            t = self._first(lambda x, t0=t0, s=s: s * self.u(x, t0, s), t0 + h, t_end)
            if t is None:
                return events
            if self.cone(t) >= 0.0:
                events.append((t, "stick"))
                resting = True
            else:
                events.append((t, "reversal"))
                s = math.copysign(1.0, math.cos(self.w * t))
        return events


def _type_of(events, t_end, period):
    """The closed form's type: its stops in the last period, counted."""
    last = [k for t, k in events if k in ("stick", "reversal") and t > t_end - period]
    if not last:
        return modes.AT_REST
    rests = last.count("stick")
    return {0: modes.TYPES[0], 1: modes.TYPES[1], 2: modes.TYPES[2]}[rests] \
        if len(last) == 2 else f"{len(last)} stops"


PERIODS = 40


def _cells_against_the_closed_form(cells, periods=PERIODS):
    types, statuses, results, st, _ = modes.run(cells, periods, workers=1)
    T = st.period
    out = []
    for (mu, beta), typ, res in zip(cells, types, results):
        M = st.body_mass(beta)
        ref = Coulomb1D(M, st.m, st.r, st.w, mu, st.g).run(periods * T)
        ours = modes.stops(res.events)
        theirs = [t for t, k in ref if k in ("stick", "reversal")]
        out.append((mu, beta, res.status, typ, _type_of(ref, periods * T, T), ours, theirs))
    return out


def test_the_three_types_and_every_stop_agree_with_the_one_dimensional_model():
    """At the example's beta (M = 1: 0.4705) the three types appear as mu grows (0.1: two
    reversals a period; 0.3: a rest and a reversal; 0.4: two rests), and at other
    corners of the plane; the runtime's type is the 1-D model's and every stop of 40
    periods is at its time to 1e-8 s."""
    beta0 = modes.example()[1].beta(1.0)
    assert abs(beta0 - 0.4705) < 1e-4
    cells = [(0.1, beta0), (0.3, beta0), (0.4, beta0), (0.6, 0.8), (0.2, 0.25),
             (0.15, 0.9)]
    got = _cells_against_the_closed_form(cells)
    assert [g[3] for g in got[:3]] == list(modes.TYPES)
    assert set(g[3] for g in got) == set(modes.TYPES)
    for mu, beta, status, typ, ref_type, ours, theirs in got:
        assert status == "done" and typ == ref_type, (mu, beta, typ, ref_type)
        assert len(ours) == len(theirs) >= 2 * PERIODS - 1, (mu, beta, len(ours), len(theirs))
        assert np.abs(np.array(ours) - theirs).max() < 1e-8, (mu, beta)


def test_the_rest_holds_below_its_closed_form_boundary():
    """|beta cos| <= mu (1 - beta sin) at every phase iff beta <= mu/sqrt(1 + mu^2):
    below it the body never moves (no event at all), just above it slips and stops."""
    mu = 0.5
    edge = float(modes.rest_limit(mu))
    assert abs(edge - 0.5 / math.sqrt(1.25)) < 1e-15
    types, statuses, results, _, _ = modes.run([(mu, edge * 0.99), (mu, edge * 1.02)], 4,
                                               workers=1)
    assert types[0] == modes.AT_REST and results[0].events == []
    assert types[1] != modes.AT_REST and modes.stops(results[1].events)


# Stops against the 1-D model at two cells where the base runtime had missed one (80 stops
# in 40 periods at both).  At mu = 0.08, beta = 0.4 O's velocity changed sign at t = 39.502 T
# with no reversal written, a slip in arc time ending at rho = eps; the slip along a line in
# t (crt_base.h: its stop the sign change of the speed along the line) writes all 80, to
# 7e-13 s.  At mu = 0.8, beta = 0.625, 1.0005 times the rest's edge, the rest breaks twice a
# period for 4.7 ms each (1.5 % of it: phases 0.102-0.117 and 0.388-0.403 in the 1-D model),
# shorter than the stick's sample (hmax/8, 6 ms here): the stick's samples now shrink by
# each function's distance to 0 over its observed rate and look at the minimum inside a
# sample (crt_base_sample_step), and all 80 are written, to 4e-10 s.
@pytest.mark.parametrize("cell", [(0.08, 0.4), (0.8, 0.625)])
def test_no_stop_is_missed(cell):
    (mu, beta, status, typ, ref_type, ours, theirs), = _cells_against_the_closed_form([cell])
    assert len(ours) == len(theirs)
    assert np.abs(np.array(ours) - theirs).max() < 1e-8


def test_the_cell_once_called_tipping_reverses():
    """mu 0.8, beta 0.95 ended `tipping` at 0.12208 s, the first stop, where the rest's cp
    is off the face but the rest cannot hold: the body reverses (crt_base_settle decides
    the mode before the margins).  Its type and every stop of 10 periods are the 1-D
    model's, and its first stops the reference integrator's (derive/base_reference.py,
    whose cp of the slips stays on the face) to 1e-9 s."""
    from derive import base_reference as br
    from derive.verify.judges import face_system
    (mu, beta, status, typ, ref_type, ours, theirs), = _cells_against_the_closed_form(
        [(0.8, 0.95)], periods=10)
    assert status == "done" and typ == ref_type == modes.TYPES[1]
    assert len(ours) == len(theirs) == 20
    assert np.abs(np.array(ours) - theirs).max() < 1e-8
    _, _, results, _, _ = modes.run([(0.8, 0.95)], 2, workers=1)
    run = results[0]
    ref = br.Integrator(face_system(run.scene)).run(run.model_q[0], 0.0, 0.45)
    assert ref.status == "done"
    mine = [(e["t"], e["kind"]) for e in run.events if e["t"] < 0.45]
    assert [k for _, k in mine] == [k for _, k in ref.events] == ["slip", "reversal", "stick",
                                                                   "slip", "reversal"]
    assert max(abs(a - b) for (a, _), (b, _) in zip(mine, ref.events)) < 1e-9


def test_the_type_is_read_from_the_last_two_periods():
    """mode_type on events made by hand: a drifting stop is not settled, a missing one
    neither; a rest held throughout is at rest; other counts are named."""
    T = 1.0
    ev = [{"t": k + p, "kind": kind} for k in range(6) for p, kind in
          ((0.3, "reversal"), (0.7, "stick"), (0.8, "slip"))]
    assert modes.mode_type(ev, 6.0, T) == modes.TYPES[1]
    drift = [dict(e, t=e["t"] + 1e-4 * (e["t"] > 5)) for e in ev]
    assert modes.mode_type(drift, 6.0, T) == modes.NOT_SETTLED
    gone = [e for e in ev if not (e["kind"] == "reversal" and e["t"] > 4.9)]
    assert modes.mode_type(gone, 6.0, T) == modes.NOT_SETTLED
    assert modes.mode_type([], 6.0, T) == modes.AT_REST
    assert modes.mode_type(ev[:2], 6.0, T) == modes.AT_REST        # held since 0.7
    assert modes.mode_type(ev[:3], 6.0, T) == "sliding without a stop"
    one = [{"t": k + 0.5, "kind": "stick"} for k in range(6)]
    assert modes.mode_type(one, 6.0, T) == "1 rest and 0 reversals"
    odd = [{"t": k + 0.5, "kind": "reversal"} for k in range(6)]          # u: +, -, +, ...
    assert modes.mode_type(odd, 6.0, T) == modes.ODD
    with pytest.raises(ValueError, match="two whole periods"):
        modes.mode_type(ev, 1.5, T)


def test_derive_chart_modes_writes_the_map_and_refuses_bad_axes(tmp_path, capsys):
    assert main(["chart", "modes", "--x", "mu=0.1,0.4", "--y", "beta=0.2,0.4705",
                 "--periods", "12", "-o", str(tmp_path), "-q"]) == 0
    out = capsys.readouterr().out
    assert "4 cells" in out and "two rests" in out
    rows = (tmp_path / "modes.csv").read_text().splitlines()
    assert rows[0].startswith("mu,beta,body_mass,status,type") and len(rows) == 5
    assert json.loads((tmp_path / "modes.json").read_text())["periods"] == 12
    assert (tmp_path / "modes.png").stat().st_size > 10_000
    for argv, said in ((["--x", "nu=0.1"], "--x: must be mu="),
                       (["--y", "beta=0.5:1.2:3"], "--y: beta must be in (0, 1)"),
                       (["--family", "C4.1"], "--family: not read by chart modes"),
                       (["--periods", "1"], "--periods: must be")):
        assert main(["chart", "modes", *argv, "-o", str(tmp_path / "x")]) == 2
        err = capsys.readouterr().err
        assert said in err and len(err.strip().splitlines()) == 1, err


# ---- the flat-foot stand-in against the base model ----------------------------------------
def _crawler(duration):
    doc = tomllib.loads(CRAWLER.read_text())
    doc["point"] = doc["point"][0]
    doc["plane"]["static_friction"] = doc["plane"]["friction"]     # the stand-in's one mu
    doc["run"]["duration"] = duration
    return doc


def _foot(duration):
    """The crawler's body on a small sphere: radius 1 cm centred 3 cm below O, so O is 4 cm
    above the floor as on the box's face; rolling resistance 0.1 m, the face's half
    length (|T| <= mu_r N: the centre of pressure within the face); spin friction 5 cm."""
    doc = _crawler(duration)
    doc["body"] = {**{k: doc["body"][k] for k in ("mass", "inertia")}, "shape": "sphere",
                   "radius": 0.01, "center": [0.0, 0.0, -0.03]}
    doc["plane"] = {"restitution": 0.0, "friction": doc["plane"]["friction"],
                    "rolling_resistance": 0.1, "spin_friction": 0.05}
    return doc


def _x_end(res):
    x, _ = choice.horizontal_of_c(res.model, res.scene.t0, float(res.t[-1]), res.model_q[-1],
                                  choice.start_of_c(res.scene), res.scene)
    return x - res.scene.com[0]


def test_the_flat_foot_stand_in_crawls_as_the_base_model():
    """The 1-D capsule (capsule-crawler.toml with mu_s = mu = 0.3) on its face (base) and
    on the stand-in (rough: a point contact whose couples hold it from rolling and
    spinning).  While the couples hold, the stand-in's equations along the plane are the
    base model's -- (M + m) X'' = F - m x'', N = (M + m) g, |F| <= mu N -- so they differ
    only by where each runtime locates its stick and slip events and by the stand-in's
    start (it settles onto its contact point in 4e-7 s): measured 3e-13 m a period
    (of 0.525 mm) and 2e-11 s; held to 1e-10 m and 1e-9 s."""
    T = 2 * math.pi / 12
    base = derive.simulate(_crawler(10 * T))
    foot = derive.simulate(_foot(10 * T))
    assert (base.model, base.status, foot.model, foot.status) == ("base", "done", "rough",
                                                                  "done")
    kinds = [e["kind"] for e in foot.events]
    assert not {"roll_start", "spin_start"} & set(kinds)         # the couples held
    per_base, per_foot = _x_end(base) / 10, _x_end(foot) / 10
    assert 4e-4 < per_base < 6e-4 and abs(per_foot - per_base) < 1e-10
    ev = [[(e["t"], e["kind"]) for e in r.events if e["kind"] in ("stick", "slip")]
          for r in (base, foot)]
    assert [k for _, k in ev[0]] == [k for _, k in ev[1]] and len(ev[0]) == 39
    assert max(abs(a - b) for (a, _), (b, _) in zip(*ev)) < 1e-9


# ---- the sweep of mean speed against friction and frequency ------------------------------
def test_a_formula_swept_by_its_number_gives_the_mean_speed_of_the_closed_form(tmp_path,
                                                                           capsys):
    """``--sweep 'point.law[0]=... for W=12,6'`` writes the law with W in; at W = 12 the
    mean speed over ten whole periods is the 1-D stick-slip closed form's (1e-9 m/s); at
    W = 6 the stroke's acceleration never breaks the rest: 0."""
    import test_base_scene as bs
    from derive.scene import toml
    T = 2 * math.pi / 12
    doc = _crawler(10 * T)
    doc["plane"]["static_friction"] = 0.35
    scene = tmp_path / "c.toml"
    scene.write_text(toml.dumps(doc))
    law = "0.05*(sin(W*t) + 0.4*sin(2*W*t))"
    assert main(["simulate", str(scene), "--sweep", f"point.law[0]={law} for W=12,6",
                 "--sweep", "plane.friction=0.3,0.25", "--plot", "mean_speed", "-o",
                 str(tmp_path / "s"), "-q"]) == 0
    capsys.readouterr()
    rows = (tmp_path / "s" / "sweep.csv").read_text().splitlines()
    head = rows[0].split(",")
    assert "mean_speed" in head and len(rows) == 5
    import csv
    table = list(csv.DictReader((tmp_path / "s" / "sweep.csv").open()))
    first = table[0]
    assert first["point_law_0"] == "0.05*(sin((12)*t) + 0.4*sin(2*(12)*t))"
    assert first["plane_friction"] == "0.3"
    speed = bs.closed_X(10 * T) / (10 * T)
    assert speed > 0 and abs(float(first["mean_speed"]) - speed) < 1e-9
    assert abs(float(first["mean_velocity_X"]) - speed) < 1e-9
    assert float(first["mean_velocity_Y"]) == 0.0
    assert abs(float(first["mean_speed"]) - float(first["distance"]) / (10 * T)) < 1e-15
    slow = [r for r in table if r["point_law_0"].startswith("0.05*(sin((6)")]
    assert len(slow) == 2 and all(float(r["mean_speed"]) < 1e-15 for r in slow)
    meta = json.loads((tmp_path / "s" / "sweep.json").read_text())
    assert meta["swept_by"] == {"point.law[0]": {"name": "W", "values": [12.0, 6.0]}}
    assert (tmp_path / "s" / "sweep.png").exists()
    assert main(["simulate", str(scene), "--sweep", "point.law[0]=0.05*sin(t) for W=1,2",
                 "-o", str(tmp_path / "t")]) == 2
    err = capsys.readouterr().err
    assert "W does not appear in the formula" in err and len(err.strip().splitlines()) == 1


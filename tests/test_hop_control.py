"""Per-hop feedback on the Poincare map of the reference-[5] hop, and the mirror law.

Checks against what is computed another way: the hop map's Jacobian from the variational
equations and the saltation matrix against finite differences of the hybrid runtime
(here with the exact sine law, through derive.stability.bouncing, not the controller's
sampled law); its vertical multipliers against the table's closed form; the closed
loop's per-hop convergence against the eigenvalues of A - B K; an orbit unstable open
loop (past period doubling) held by the feedback; the apex a target sets, measured on
the run; the mirror law's apex on the run.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from derive import layout
from derive.control import hop as H
from derive.control.closed import simulate_closed
from derive.runtime.driver import prepare, run_prepared
from derive.runtime.loop import Loop
from derive.scene import parse_scene, toml
from derive.stability import bouncing

UNSTABLE = 0.1            # a: Gamma = 1.83 beyond the period doubling at 1.53 (e = 0.5)


@pytest.fixture(scope="module")
def unstable():
    sc = parse_scene(bouncing.bouncing_scene(a=UNSTABLE))
    hm = H.HopMap(sc)
    return hm, H.design(hm, hm.gait)


def _exact_section_map(doc):
    """The impact-to-impact map in section coordinates by the hybrid runtime with the
    scene's own (exact) law, written from derive.stability.bouncing's pieces."""
    hybrid = bouncing.HybridMap(doc)
    T = 2 * math.pi / bouncing.reference5(hybrid.scene)["W"]

    def P(x):
        q0 = bouncing._unpack(x[1:], x[0], hybrid)
        t1, q1 = hybrid.to_next_impact(x[0], q0, 1.5 * T)
        return np.r_[t1 - T, bouncing._pack(q1)]
    return P


def test_the_jacobian_of_the_hop_map_agrees_with_finite_differences(unstable):
    hm, d = unstable
    P = _exact_section_map(bouncing.bouncing_scene(a=UNSTABLE))
    x = d.orbit.x
    fd = np.column_stack([(P(x + h) - P(x - h)) / (2 * h[k])
                          for k, h in enumerate(1e-6 * np.eye(len(x)))])
    J = d.jacobian_variational
    assert np.max(np.abs(fd - J)) < 1e-5 * max(1.0, np.max(np.abs(J)))
    # the controller's own finite differences (its sampled law) agree to its sampling
    assert np.max(np.abs(d.jacobian_fd[:, :7] - J)) < 2e-3 * np.max(np.abs(J))


def test_the_vertical_multipliers_are_the_tables(unstable):
    hm, d = unstable
    sc = hm.scene
    nu = sc.m / (sc.m + sc.M)
    Gamma = nu * UNSTABLE * 30.0 ** 2 / sc.g
    table = bouncing.table_orbit(sc.e, 1, Gamma)["multipliers"]
    assert np.allclose(np.sort_complex(d.open_loop), np.sort_complex(table), atol=1e-7)
    assert max(abs(d.open_loop)) > 2.0              # unstable: period doubling passed


def _deviations(hm, design, controller, hops=14, dv=2e-3):
    """Scaled deviations (phase in rad, velocity relative) at the impacts of a run from
    the orbit with C's velocity off by dv."""
    import dataclasses
    orbit = design.orbit
    q0 = H._state(hm, orbit.x + np.r_[0.0, dv, 0, 0, 0, 0, 0])
    T = orbit.gait.period
    scene = dataclasses.replace(hm.scene, t0=orbit.t, duration=(hops + 0.5) * T,
                                com=(0.0, 0.0, q0[0]), com_velocity=(0.0, 0.0, q0[1]))
    res = run_prepared(prepare(scene), loop=Loop(controller))
    rows = np.flatnonzero(res.row_kind == 2)
    dt = (res.t[rows] - orbit.t + 0.5 * T) % T - 0.5 * T
    dv = res.model_q[rows, 1] - orbit.v
    return np.hypot(orbit.gait.W * dt, dv / orbit.v)


def test_feedback_holds_an_orbit_unstable_open_loop_at_the_predicted_rate(unstable):
    hm, d = unstable
    open_dev = _deviations(hm, d, H.OpenLoopGait(hm.gait), hops=8, dv=1e-4)
    assert open_dev[-1] > 30 * open_dev[0]          # |rho| = 2.016: it runs away
    closed = _deviations(hm, d, H.HopController(d))
    lam = max(abs(d.closed_loop))
    rate = (closed[9] / closed[3]) ** (1 / 6)       # in the linear range
    assert closed[-1] < 1e-6 * closed[0]
    assert abs(rate - lam) < 0.25 * lam, (rate, lam)


def test_a_deadbeat_gain_settles_in_three_hops(unstable):
    hm, _ = unstable
    d = H.design(hm, hm.gait, gain="deadbeat", orbit=unstable[1].orbit)
    Acl = d.A - d.B @ d.K                 # nilpotent (its eigenvalues only to eps^(1/3))
    assert np.max(np.abs(np.linalg.matrix_power(Acl, 3))) < 1e-9 * np.max(np.abs(d.A)) ** 3
    dev = _deviations(hm, d, H.HopController(d), hops=6, dv=1e-4)
    assert dev[4] < 0.02 * dev[0]


def test_the_apex_a_target_sets_is_the_runs():
    doc = bouncing.bouncing_scene(a=0.07)
    doc["control"] = {"mode": "hop", "apex_height": 0.09, "duration": 3.0}
    out = simulate_closed(doc)
    assert out.result.status == "done"
    assert out.target["apex_height"] == pytest.approx(0.09, abs=1e-8)
    res = out.result
    R = 0.5
    imp = res.impacts[:, 0]
    Z = res.model_q[:, 0]
    apexes = [Z[(res.t > a) & (res.t < b)].max() - R for a, b in zip(imp[:-1], imp[1:])]
    assert abs(apexes[-1] - 0.09) < 2e-4 and abs(apexes[0] - 0.09) > 5e-3


def test_the_mirror_law_brings_the_apex_to_its_target():
    doc = bouncing.bouncing_scene(a=UNSTABLE)
    doc["initial"].update(com=[0.0, 0.0, 0.6], com_velocity=[0.0, 0.0, 0.0], time=0.0)
    doc["control"] = {"mode": "mirror", "apex_height": 0.05, "duration": 5.0}
    res = simulate_closed(doc).result
    Z, imp = res.model_q[:, 0], res.impacts[:, 0]
    apexes = [Z[(res.t > a) & (res.t < b)].max() - 0.5 for a, b in zip(imp[:-1], imp[1:])]
    assert np.allclose(apexes[-3:], 0.05, atol=2e-4)


def test_derive_simulate_runs_a_scene_with_a_control_table(tmp_path):
    doc = bouncing.bouncing_scene(a=UNSTABLE)
    doc["initial"]["com_velocity"][2] += 0.02
    doc["run"].update(duration=2.0, outputs=["omega", "height", "impacts"])
    doc["control"] = {"mode": "hop"}
    path = tmp_path / "hop.toml"
    path.write_text(toml.dumps(doc))
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", str(path), "-o",
                           str(out), "-q", "--no-plots"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    info = json.loads((out / "control.json").read_text())
    assert info["mode"] == "hop" and info["law_changes"] == info["impacts"] + 1
    deviations = [np.abs(h["deviation"][:2]) for h in info["per_hop"]]
    assert deviations[-1][1] < 1e-4 * deviations[0][1]
    law = np.genfromtxt(out / "law.csv", delimiter=",", names=True)
    assert law["t"][0] == pytest.approx(doc["initial"]["time"])
    bad = path.read_text().replace('mode = "hop"', 'mode = "replan"')
    path.write_text(bad)
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", str(path), "-o",
                           str(tmp_path / "bad")], capture_output=True, text=True)
    assert proc.returncode == 2 and "[control].mode" in proc.stderr


# ---- the controller in C ------------------------------------------------------------------
def test_the_c_controller_writes_the_python_routes_law_to_the_bit(unstable):
    """crt_hop.c, called by the C runtime with no Python per call, against
    HopController through ctypes: the same laws, the same run."""
    import dataclasses
    hm, d = unstable
    doc = bouncing.bouncing_scene(a=UNSTABLE)
    doc["initial"]["com_velocity"][2] += 0.02
    doc["run"]["duration"] = 2.0
    prep = prepare(parse_scene(doc))
    loops = [Loop(H.HopController(d)), Loop(H.c_controller(d))]
    runs = [run_prepared(prep, loop=lp) for lp in loops]
    assert runs[0].stats["law_changes"] == runs[1].stats["law_changes"] > 5
    assert np.array_equal(loops[0].law_rows(), loops[1].law_rows())
    assert np.array_equal(runs[0].q, runs[1].q)
    del dataclasses


def test_where_impacts_stop_the_gait_goes_on_bounded_in_both_routes(unstable):
    """A trial's hop controller set the law only at impacts, three gait periods at a time;
    where the impacts stopped (the body came to rest on the plane) the law's last cubic
    went on, z reaching -36 m, and the run still said done.  With a sample every gait
    period the controller (Python and C alike, to the bit) goes on with the gait before
    its law ends: the law covers the run and stays within the gait's amplitude."""
    from derive.runtime.loop import realised_law
    hm, d = unstable
    doc = bouncing.bouncing_scene(a=UNSTABLE)
    doc["plane"]["restitution"] = 0.0                 # it lands and rests: no more impacts
    doc["run"]["duration"] = 2.0
    prep = prepare(parse_scene(doc))
    g = d.orbit.gait
    loops = [Loop(H.HopController(d), period=g.period),
             Loop(H.c_controller(d), period=g.period)]
    runs = [run_prepared(prep, loop=lp) for lp in loops]
    assert runs[0].status == runs[1].status == "done"
    assert np.array_equal(loops[0].law_rows(), loops[1].law_rows())
    assert np.array_equal(runs[0].q, runs[1].q)
    impacts = len(runs[0].impacts)
    assert runs[0].stats["law_changes"] > impacts + 1       # laws set where no impact came
    law = realised_law(loops[0].law_rows())
    t_end = prep.scene.t0 + prep.scene.duration
    assert law.knots[-1] >= t_end
    z = law.jets(np.linspace(law.t_first, t_end, 4001))[layout.JET_R[2]]
    assert np.max(np.abs(z)) <= 1.5 * g.a * (1 + 1e-9)


C_LOOP = """
#include "model_vertical.c"
#include "crt_hop.c"
#include <stdio.h>
%(law_data)s
int main(void)
{
  static const double opt[CRT_OPT_COUNT] = {%(opt)s};
  static const double prm[CRT_P_COUNT] = {%(prm)s};
  static const double q0[NQ] = {%(q0)s};
  static const double noise[4] = {0.001, 0.0005, 0.0, 0.001};
  crt_session s;
  crt_control c;
  crt_hop_params P = {{%(K)s}, %(t_star)s, %(v_star)s, %(a)s, %(W)s, %(T)s, %(tb)s, %(h)s,
                      0.5, %(n)s, %(zd)s, %(a)s, -HUGE_VAL};
  double t[16], q[16 * NQ], ev[8 * CRT_EVENT_COLUMNS], log[512 * CRT_LOG_COLUMNS];
  int kind[16], n, n_ev, status, rows = 0, logged = 0;
  if (%(set_law)s != CRT_OK) return 3;
  if (crt_control_setup(&c, crt_hop_controller, &P, 0.0, noise, 7.0, 0, 0, log, 512)
      != CRT_OK) return 4;
  if (crt_set_control(&s, &c) != CRT_OK) return 5;
  if (crt_init(&s, opt, prm, %(t0)s, q0) != CRT_OK) return 6;
  do {
    status = crt_advance(&s, %(t1)s, t, q, kind, 16, &n, ev, 8, &n_ev);
    rows += n;
    logged += crt_control_log_count(&c);
    crt_control_log_taken(&c);
  } while (status == CRT_PAUSED);
  crt_set_control(&s, 0);
  printf("status %%s rows %%d logged %%d calls %%ld\\n", crt_status_name(status), rows,
         logged, (long)s.stat[CRT_STAT_CONTROLLER_CALLS]);
  return status == CRT_DONE && logged > 100 ? 0 : 1;
}
"""


def test_a_closed_loop_in_c_is_clean_under_sanitizers(unstable, tmp_path):
    """The model's runtime and crt_hop.c in one C program, no Python: strict C99, ASan
    and UBSan, the pause and resume of the loop's log; and crt_hop.c has no writable
    statics and needs only libm."""
    import shutil
    from derive.paths import GENERATED
    from test_runtime_c import scene_fields
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    hm, d = unstable

    def make():
        doc = bouncing.bouncing_scene(a=UNSTABLE)
        doc["initial"]["com_velocity"][2] += 0.02
        doc["run"].update(duration=1.5, outputs=["omega", "impacts"])
        return doc
    f = scene_fields(make, ["lie"])
    g, o = d.orbit.gait, d.orbit
    src = tmp_path / "main.c"
    src.write_text(C_LOOP % {
        **f, "opt": f["opts"][1:-1], "K": ", ".join(repr(float(k)) for k in d.K.ravel()),
        "t_star": repr(o.t), "v_star": repr(o.v), "a": repr(g.a), "W": repr(g.W),
        "T": repr(g.period), "tb": repr(H.BLEND * g.period),
        "h": repr(g.period / H.KNOTS_PER_PERIOD),
        "n": str(int(round(H.SPAN * H.KNOTS_PER_PERIOD))), "zd": str(hm.V.Zd)})
    exe = tmp_path / "main"
    strict = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
    build = subprocess.run([cc, *strict, "-O0", "-g", "-fsanitize=address,undefined",
                            "-fno-sanitize-recover=all", "-I", str(GENERATED / "runtime"),
                            "-I", str(GENERATED / "control"), str(src), "-o", str(exe), "-lm"],
                           capture_output=True, text=True)
    assert build.returncode == 0, build.stderr[-3000:]
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr[-3000:]
    assert "runtime error" not in run.stderr
    obj = tmp_path / "hop.o"
    subprocess.run([cc, *strict, "-O2", "-I", str(GENERATED / "runtime"), "-c",
                    str(GENERATED / "control" / "crt_hop.c"), "-o", str(obj)], check=True)
    nm = subprocess.run(["nm", str(obj)], capture_output=True, text=True).stdout.split("\n")
    assert not [ln for ln in nm if len(ln.split()) == 3 and ln.split()[1] in "BbDdGgSs"]
    assert {ln.split()[1] for ln in nm if ln.split()[:1] == ["U"]} <= {"sin", "cos", "sincos",
                                                                     "fmod"}


def test_derive_control_refuses_hop_and_mirror_and_says_where_they_run(tmp_path, capsys):
    """hop and mirror close the loop around a scene's gait: derive control (a planned
    task) refuses them in one line naming [control].mode and pointing at derive
    simulate; nothing is written."""
    from derive.cli import main
    task = (Path(__file__).resolve().parents[1] / "derive" / "planner" / "examples" /
            "land.toml").read_text()
    for mode in ("hop", "mirror"):
        path = tmp_path / f"{mode}.toml"
        path.write_text(task + f'\n[control]\nmode = "{mode}"\n')
        out = tmp_path / f"out-{mode}"
        assert main(["control", str(path), "-o", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "[control].mode" in err[0] and "derive simulate" in err[0]
        assert not out.exists()
    # the hop example itself is a scene (no [plan]): told the same, not "[plan] required"
    scene = Path(__file__).resolve().parents[1] / "derive" / "control" / "examples" / "hop.toml"
    assert main(["control", str(scene), "-o", str(tmp_path / "out-scene")]) == 2
    err = capsys.readouterr().err.strip()
    assert "[control].mode: hop closes the loop around a scene's gait" in err


def test_a_controllers_wider_gait_does_not_let_s_through_the_plane():
    """The example hop at e = 0.8: the per-hop controller widens the gait beyond the
    scene's own law, whose reach bounded |n.CS| in the runtime's test that S cannot reach
    the plane inside a step (crt_events.h); S went 2.6 mm below the plane inside a step
    and the impact was found only at its end, the run 'done'.  Now, once a controller has
    set a law, every step is sampled: S never below the penetration tolerance (well under
    a micrometre here), checked on the rows and against the law the loop ran (P's height
    and C's give S's, computed here from the general layout's rows)."""
    import tomllib
    from importlib import resources
    doc = tomllib.loads((resources.files("derive.control") / "examples" / "hop.toml")
                        .read_text(encoding="utf-8"))
    doc.pop("disturbance")
    doc["plane"]["restitution"] = 0.8
    res = simulate_closed(parse_scene(doc)).result
    assert res.status == "done" and res.stats["law_changes"] > 1
    assert res.min_height > -1e-9, res.min_height
    assert float(np.min(res.height)) > -1e-9


def _call_c(ctrl, t, reason, event, q, u):
    """One call of a C controller (crt_controller_fn) from Python: (status, knots, coef)."""
    import ctypes
    from derive.runtime.loop import CONTROLLER_FN, MAX_KNOTS, CallStruct
    dp = ctypes.POINTER(ctypes.c_double)
    q, u = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(u, dtype=float)
    call = CallStruct(t, reason, event, len(q), q.ctypes.data_as(dp), u.ctypes.data_as(dp), 0)
    knots, coef, n = np.zeros(MAX_KNOTS), np.zeros(12 * MAX_KNOTS), ctypes.c_int(0)
    fn = CONTROLLER_FN(ctrl.address)
    r = fn(ctypes.addressof(ctrl.ctx), ctypes.byref(call), MAX_KNOTS, ctypes.byref(n),
           knots.ctypes.data_as(dp), coef.ctypes.data_as(dp))
    return r, knots[:n.value], coef[:12 * max(n.value - 1, 0)].reshape(-1, 3, 4)


@pytest.mark.parametrize("share", [0.98, 1.02])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_the_gait_correction_is_clamped_at_its_limit_and_a_law_renewed_a_period_before_its_end(
        unstable, share, sign):
    """crt_hop.c called directly, beside HopController (the same law to the bit at each
    call).  The start, from a law off the axis: x and y go from its value and rate to 0
    over the first piece and stay there.  Before any impact, and again after one, a
    sample 2 % of a period before the law's end less a period leaves the law alone (0),
    and 2 % after renews it.  An impact at the orbit's phase and gait whose velocity
    deviation asks a correction delta = sign * share * limit * a*:
    within the limit the new gait's amplitude is a* + delta, beyond it a* +- limit a* (the
    law's z at its last knot, past the blend, is a sin(W t): the closed form).  The
    start is late (30 periods in) so that 5 % of a threshold would move either sample."""
    from derive.layout import VERTICAL
    from derive.runtime.loop import EVENTS, Call
    hm, d = unstable
    orbit, g = d.orbit, d.orbit.gait
    limit, T = 0.5, g.period
    py, c = H.HopController(d), H.c_controller(d)
    t0 = orbit.t + 30 * T
    q = np.zeros(VERTICAL.nq)
    u = np.zeros(9)
    u[2], u[5] = g.jet(t0)[0], g.jet(t0)[1]
    u[[0, 1, 3, 4]] = 0.01, -0.02, 0.3, 0.1         # the law in use off the axis
    r, knots, coef = _call_c(c, t0, 0, 0, q, u)                # the start: the design's gait
    law = py(Call(t0, "start", "", q, u, 0))
    assert r == 1 and np.array_equal(knots, law.knots) and np.array_equal(
        coef, law.coef.reshape(-1, 3, 4))
    # x and y: from the law's at t0 to the axis over the first piece, then on it
    assert np.array_equal(law.at(t0)[[0, 1, 3, 4]], u[[0, 1, 3, 4]])
    assert np.all(law.at(knots[1])[[0, 1, 3, 4]] == 0.0)
    assert np.all(law.coef[1:, :2, :] == 0.0)
    # before any impact: a sample 2 % of a period either side of (the start's law's end
    # less a period) leaves it (0), or renews it
    for offset, renewed in ((-0.02 * T, False), (0.02 * T, True)):
        ts = knots[-1] - T + offset
        r, _, _ = _call_c(c, ts, 1, 0, q, law.at(ts))
        got = py(Call(ts, "sample", "", q, law.at(ts), 1))
        assert (r == 1) == renewed and (got is not None) == renewed, (offset, r)
    t0 = knots[-1] - T + 0.02 * T                              # the law renewed there
    law = got
    # an impact a whole number of periods after the orbit's: phase and gait deviations 0
    ti = orbit.t + 33 * T
    delta = sign * share * limit * g.a
    q[VERTICAL.Zd] = orbit.v - delta / d.K[0, 1]
    u = law.at(ti)
    impact = EVENTS.index("impact")
    r, knots, coef = _call_c(c, ti, 2, impact, q, u)
    law = py(Call(ti, "event", "impact", q, u, 1))
    assert r == 1 and np.array_equal(knots, law.knots) and np.array_equal(
        coef, law.coef.reshape(-1, 3, 4))
    a_new = g.a + sign * min(share, 1.0) * limit * g.a
    assert py.history[-1][2] == pytest.approx(sign * min(share, 1.0) * limit * g.a, rel=1e-9)
    end = knots[-1]
    assert law.at(end)[2] == pytest.approx(a_new * np.sin(g.W * end), rel=1e-6, abs=1e-9)
    # no impact: a sample 2 % of a period either side of (the law's end - a period)
    for offset, renewed in ((-0.02 * T, False), (0.02 * T, True)):
        ts = end - T + offset
        u = law.at(ts)
        r, knots2, _ = _call_c(c, ts, 1, 0, q, u)
        got = py(Call(ts, "sample", "", q, u, 2))
        assert (r == 1) == renewed and (got is not None) == renewed, (offset, r)
        if renewed:
            assert np.array_equal(knots2, got.knots)

def test_a_loop_stopped_by_max_events_logs_its_law_to_the_stop(unstable):
    """The C controller's loop stopped by [run].max_events = 4 (its fourth event, mid-
    run): the realised law's rows end at the stop, not at the last law change before it,
    and on [t0, stop] it is the uninterrupted run's law (2 s, the same controller) to
    1e-12 (its pieces re-expanded about other times where the logs split them): the law
    the loop ran is written to its end even when the run ends early."""
    from derive.runtime.loop import realised_law
    hm, d = unstable
    doc = bouncing.bouncing_scene(a=UNSTABLE)
    doc["run"]["duration"] = 2.0
    full_loop = Loop(H.c_controller(d))
    full = run_prepared(prepare(parse_scene(doc)), loop=full_loop)
    doc["run"]["max_events"] = 4
    loop = Loop(H.c_controller(d))
    run = run_prepared(prepare(parse_scene(doc)), loop=loop)
    assert full.status == "done" and run.status == "max_events"
    t_stop = run.events[3]["t"]
    assert run.t[-1] == t_stop < full.t[-1]
    rows = loop.law_rows()
    assert rows[-1, 2] == t_stop
    ts = np.linspace(rows[0, 1], t_stop, 401)
    a, b = realised_law(rows).jets(ts), realised_law(full_loop.law_rows()).jets(ts)
    assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b)), np.max(np.abs(a - b))

"""The runtime's return codes say what happened (derive/abi.py STATUSES, in the
manner of SUNDIALS' CVODE: 0 success, positive stops, negative errors).

* Output buffers smaller than CRT_MIN_ROWS rows or CRT_MIN_EVENTS events are refused
  with bad_argument by crt_advance, crt_run and crt_run_many.  Before, crt_advance
  returned "paused" with no rows, so crt_run_many's loop (and Session.run's) never
  ended: the C program below hung (it runs in a subprocess with a timeout, so a
  regression fails instead of hanging the suite).
* A malformed law is bad_law (it was bad_options), and so is crt_init without a law.
* Every option rule of crt_init (abi.OPTIONS' third field) is broken in turn: the code
  is bad_options and crt_bad_option names that option; Python's error names it too.
  A non-finite parameter is bad_parameters, named by crt_bad_parameter.
* crt_status_name and abi.py agree on every code, negative ones included, and so does
  the enum of crt_abi.h.
"""
from __future__ import annotations

import ctypes
import math
import re
import subprocess

import numpy as np
import pytest

from derive.paths import GENERATED
from derive import abi, shapes
from derive.runtime.build import DP, IP, library
from derive.runtime.driver import prepare
from derive.runtime.session import Session
from derive.scene import SceneError

from test_runtime import ball
from test_runtime_c import CC, STRICT, scene_fields

S = abi.STATUS


def _scene():
    return ball(e=0.5, z0=1.0, duration=1.0)


# ---- the defect: too-small buffers hung crt_run_many -------------------------------------
RUN_MANY = """
#include "model_%(kind)s.c"
#include <stdio.h>
#include <stdlib.h>
%(law_data)s
static const double opts[%(n_methods)s][CRT_OPT_COUNT] = {%(opts)s};

int main(int argc, char **argv)
{
  /* rows and events the buffers claim (of 16 and 8) */
  const int cap = argc > 2 ? atoi(argv[1]) : 16, ev_cap = argc > 2 ? atoi(argv[2]) : 8;
  static const double prm[CRT_P_COUNT] = {%(prm)s};
  static const double q0[NQ] = {%(q0)s};
  const double t0[1] = {%(t0)s}, t1[1] = {%(t1)s};
  crt_session s;
  double t[16], q[16 * NQ], ev[8 * CRT_EVENT_COLUMNS], summ[CRT_SUMMARY_COUNT];
  double last[1 + NQ], first[1];
  long stats[CRT_STAT_COUNT];
  int kind[16], init[1], st[1], status;
  status = %(set_law)s;
  if (status != 0 || cap > 16 || ev_cap > 8) return 3;
  crt_run_many(&s, 1, opts[0], prm, t0, q0, t1, t, q, kind, cap, ev, ev_cap, init, st, stats,
               summ, last, first);
  printf("%%d %%s %%ld\\n", st[0], crt_status_name(st[0]), stats[0]);
  return 0;
}
"""


@pytest.fixture(scope="module")
def run_many_program(tmp_path_factory):
    """(cap, ev_cap) -> the output of a C program that calls crt_run_many once with
    buffers of that size (compiled once under ASan and UBSan, run with a timeout)."""
    folder = tmp_path_factory.mktemp("run_many")
    src, exe = folder / "main.c", folder / "main"
    src.write_text(RUN_MANY % scene_fields(_scene, ("dop853",)))
    proc = subprocess.run([CC, *STRICT, "-O0", "-fsanitize=address,undefined",
                           "-fno-sanitize-recover=all", "-I", str(GENERATED / "runtime"),
                           str(src), "-o", str(exe), "-lm"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]

    def run(cap: int, ev_cap: int) -> str:
        try:
            out = subprocess.run([str(exe), str(cap), str(ev_cap)], capture_output=True,
                                 text=True, timeout=20)
        except subprocess.TimeoutExpired:
            pytest.fail(f"crt_run_many with {cap} rows and {ev_cap} events hung (no "
                        "status after 20 s)")
        assert out.returncode == 0 and "runtime error" not in out.stderr, \
            out.stdout + out.stderr[-3000:]
        return out.stdout.split()
    return run


@pytest.mark.parametrize("cap, ev_cap", [(abi.MIN_ROWS - 1, 8), (4, 8),
                                         (16, abi.MIN_EVENTS - 1), (1, 1)])
def test_too_small_buffers_end_crt_run_many_with_bad_argument(run_many_program, cap,
                                                              ev_cap):
    code, name, steps = run_many_program(cap, ev_cap)
    assert (int(code), name, int(steps)) == (S["bad_argument"], "bad_argument", 0)


def test_the_smallest_buffers_run_to_the_end(run_many_program):
    """At CRT_MIN_ROWS and CRT_MIN_EVENTS crt_run_many runs (and equals a roomy run)."""
    small = run_many_program(abi.MIN_ROWS, abi.MIN_EVENTS)
    roomy = run_many_program(16, 8)
    assert small[1] == roomy[1] == "done" and small[2] == roomy[2]


# ---- the same through ctypes: crt_advance and crt_run -------------------------------------
class Raw:
    """A session of a model's library driven through ctypes, with buffers of any size."""

    def __init__(self, doc):
        self.prep = prepare(doc)
        self.lib = library(self.prep.kind)
        self.c = self.lib.lib
        self.mem = ctypes.create_string_buffer(self.lib.session_size + 64)
        self.s = ctypes.c_void_p((ctypes.addressof(self.mem) + 63) // 64 * 64)
        self.session = None

    def set_law(self) -> int:
        law = self.prep.scene.law
        self.arrays = a = law.arrays()
        return self.c.crt_set_law_program(self.s, len(a["code"]), a["n_const"],
                                          a["code"].ctypes.data_as(IP),
                                          a["consts"].ctypes.data_as(DP), len(a["consts"]),
                                          a["outputs"].ctypes.data_as(IP))

    def init(self, opt=None, prm=None) -> int:
        self.opt = np.array(self.prep.options if opt is None else opt, dtype=float)
        self.prm = np.array(self.prep.parameters if prm is None else prm, dtype=float)
        self.q0 = np.array(self.prep.start.q0, dtype=float)
        return self.c.crt_init(self.s, self.opt.ctypes.data_as(DP),
                               self.prm.ctypes.data_as(DP), float(self.prep.scene.t0),
                               self.q0.ctypes.data_as(DP))

    def buffers(self, cap, ev_cap):
        nq = self.lib.nq
        self.t, self.q = np.full(cap, -7.0), np.full((cap, nq), -7.0)
        self.k = np.full(cap, -7, dtype=np.intc)
        self.ev = np.full((ev_cap, len(abi.EVENT_COLUMNS)), -7.0)
        self.n, self.ne = ctypes.c_int(-1), ctypes.c_int(-1)
        return (self.t.ctypes.data_as(DP), self.q.ctypes.data_as(DP),
                self.k.ctypes.data_as(IP), cap, ctypes.byref(self.n),
                self.ev.ctypes.data_as(DP), ev_cap, ctypes.byref(self.ne))

    def advance(self, cap, ev_cap) -> int:
        t_end = self.prep.scene.t0 + self.prep.scene.duration
        return self.c.crt_advance(self.s, t_end, *self.buffers(cap, ev_cap))

    def untouched(self) -> bool:
        return (self.n.value == 0 and self.ne.value == 0 and np.all(self.t == -7.0)
                and np.all(self.ev == -7.0))


@pytest.mark.parametrize("cap, ev_cap", [(abi.MIN_ROWS - 1, 8), (16, abi.MIN_EVENTS - 1)])
def test_crt_advance_refuses_too_small_buffers_and_the_run_goes_on(cap, ev_cap):
    r = Raw(_scene())
    assert r.set_law() == S["ok"] and r.init() == S["ok"]
    assert r.advance(cap, ev_cap) == S["bad_argument"] and r.untouched()
    # nothing happened: with buffers large enough the run goes on from its start
    status, rows = S["paused"], []
    while status == S["paused"]:
        status = r.advance(abi.MIN_ROWS, abi.MIN_EVENTS)
        rows.append(r.t[:r.n.value].copy())
    assert status == S["done"]
    t = np.concatenate(rows)
    assert t[0] == r.prep.scene.t0 and t[-1] == pytest.approx(1.0, abs=1e-12)
    assert np.all(np.diff(t) >= 0.0)


def test_crt_run_refuses_too_small_buffers():
    r = Raw(_scene())
    assert r.set_law() == S["ok"]
    opt = np.array(r.prep.options)
    prm = np.array(r.prep.parameters)
    q0 = np.array(r.prep.start.q0)
    stats = (ctypes.c_long * len(abi.STATS))()
    summ = np.zeros(len(abi.SUMMARY))
    init = ctypes.c_int(-99)
    for cap, ev_cap in ((abi.MIN_ROWS - 1, 8), (16, abi.MIN_EVENTS - 1)):
        bufs = r.buffers(cap, ev_cap)
        status = r.c.crt_run(r.s, opt.ctypes.data_as(DP), prm.ctypes.data_as(DP), 0.0,
                             q0.ctypes.data_as(DP), 1.0, *bufs, stats,
                             summ.ctypes.data_as(DP), ctypes.byref(init))
        assert (init.value, status) == (S["ok"], S["bad_argument"]) and r.untouched()


def test_a_session_needs_the_smallest_buffers():
    lib = library(prepare(_scene()).kind)
    with pytest.raises(ValueError, match="chunk"):
        Session(lib, chunk=abi.MIN_ROWS - 1)
    Session(lib, chunk=abi.MIN_ROWS)


# ---- the law -------------------------------------------------------------------------------
def _bad_programs(a: dict):
    """Malformed variants of a valid program (code rows (op, a, b), n_const, outputs),
    one rule of crt_set_law_program broken in each."""
    code, n_const, out = a["code"], int(a["n_const"]), a["outputs"]
    n_consts = len(a["consts"])
    ops = {name: k for k, name in enumerate(abi.names(abi.OPCODES))}
    first_op = n_const                      # the first node that is not a constant
    assert first_op < len(code)

    def variant(**kw):
        c = code.copy()
        for (row, col), v in kw.get("set", {}).items():
            c[row, col] = v
        return c, kw.get("n_const", n_const), kw.get("out", out.copy()), \
            kw.get("n_nodes", len(code))
    yield "no node", variant(n_nodes=0)
    yield "too many nodes", variant(n_nodes=abi.LAW_MAX_NODES + 1)
    yield "n_const > n_nodes", variant(n_const=len(code) + 1)
    yield "opcode out of range", variant(set={(first_op, 0): len(abi.OPCODES)})
    yield "negative opcode", variant(set={(first_op, 0): -1})
    yield "a constant after the constants", variant(set={(first_op, 0): ops["const"],
                                                         (first_op, 1): 0})
    if n_const:
        yield "constant index out of range", variant(set={(0, 1): n_consts})
    yield "a node reads itself", variant(set={(first_op, 0): ops["neg"],
                                              (first_op, 1): first_op})
    if first_op > 0:
        yield "a node reads a later one", variant(set={(first_op, 0): ops["add"],
                                                       (first_op, 1): 0,
                                                       (first_op, 2): first_op + 1})
        yield "powi of a missing constant", variant(set={(first_op, 0): ops["powi"],
                                                         (first_op, 1): 0,
                                                         (first_op, 2): n_consts})
    harmonic = [k for k in range(len(code)) if code[k, 0] in (ops["hsin"], ops["hcos"])]
    if harmonic:
        yield "a harmonic past the constants", variant(set={(harmonic[0], 1): n_consts - 2})
    yield "output out of range", variant(out=np.array([0, 0, len(code)], dtype=np.intc))
    yield "negative output", variant(out=np.array([-1, 0, 0], dtype=np.intc))


def test_a_malformed_law_is_bad_law():
    doc = ball(e=0.5, z0=1.0, law=("0.05*sin(7*t)", "0.01*t", "0.3*cos(2*t)"),
               duration=1.0)
    r = Raw(doc)
    a = r.prep.scene.law.arrays()
    seen = []
    for what, (code, n_const, out, n_nodes) in _bad_programs(a):
        code = np.ascontiguousarray(code, dtype=np.intc)
        status = r.c.crt_set_law_program(r.s, n_nodes, n_const, code.ctypes.data_as(IP),
                                         a["consts"].ctypes.data_as(DP), len(a["consts"]),
                                         out.ctypes.data_as(IP))
        assert status == S["bad_law"], what
        # a refused law leaves the session without one: crt_init says so
        assert r.init() == S["bad_law"], what
        seen.append(what)
    assert len(seen) >= 9
    assert r.set_law() == S["ok"] and r.init() == S["ok"]


def test_a_malformed_table_is_bad_law_and_no_law_is_bad_law():
    r = Raw(_scene())
    coef = np.zeros(12 * 4)
    for knots in ([0.0], [0.0, 0.0, 1.0], [0.0, 2.0, 1.0], [0.0, math.nan, 1.0]):
        k = np.array(knots)
        assert r.c.crt_set_law_table(r.s, len(k), k.ctypes.data_as(DP),
                                     coef.ctypes.data_as(DP), 0) == S["bad_law"], knots
    k = np.array([0.0, 0.5, 1.0])
    assert r.c.crt_set_law_table(r.s, len(k), k.ctypes.data_as(DP),
                                 coef.ctypes.data_as(DP), 0) == S["ok"]
    assert r.init() == S["ok"]
    fresh = Raw(_scene())
    ctypes.memset(fresh.s, 0, fresh.lib.session_size)
    fresh.c.crt_set_law_table(fresh.s, 1, k.ctypes.data_as(DP), coef.ctypes.data_as(DP), 0)
    assert fresh.init() == S["bad_law"]


# ---- options and parameters, each named ----------------------------------------------------
def _breaking(option: abi.Name) -> list:
    """Values that break an option's rule (as abi.OPTIONS states it)."""
    rule = option.rule
    if option.name == "method":
        return [-1.0, float(len(abi.METHODS)), 1.5, math.nan]
    bound = {"> 0": [0.0, -1.0, math.nan], ">= 0": [-1e-300, -1.0, math.nan],
             ">= 1": [0.999, 0.0, math.nan]}
    assert rule in bound, f"{option.name}: no breaking values for the rule {rule!r}"
    return bound[rule]


CHECKED = [o for o in abi.OPTIONS if o.rule]


def test_every_checked_option_has_a_rule_the_test_can_break():
    assert [o.name for o in CHECKED] == ["method", "rtol", "atol", "hmax", "rk4_step",
                                        "max_steps", "max_events", "output_dt",
                                        "time_scale", "event_tol", "length_scale",
                                        "output_phase"]


@pytest.mark.parametrize("option", CHECKED, ids=lambda o: o.name)
def test_each_bad_option_is_named_through_the_getter(option):
    r = Raw(_scene())
    assert r.set_law() == S["ok"]
    k = abi.OPT[option.name]
    for value in _breaking(option):
        opt = np.array(r.prep.options)
        opt[k] = value
        assert r.init(opt=opt) == S["bad_options"], (option.name, value)
        assert r.c.crt_bad_option(r.s) == k, (option.name, value)
        assert r.c.crt_bad_parameter(r.s) == -1
        # Python names the option and its rule
        session = Session(r.lib, chunk=16)
        session.set_law(r.prep.scene.law)
        with pytest.raises(SceneError, match=rf"option {option.name} .*must be "
                                             rf"{re.escape(option.rule)}"):
            session.init(opt, r.prep.parameters, 0.0, r.prep.start.q0)
    # a good vector clears it
    assert r.init() == S["ok"] and r.c.crt_bad_option(r.s) == -1


def test_unchecked_options_take_any_value():
    r = Raw(_scene())
    assert r.set_law() == S["ok"]
    for option in abi.OPTIONS:
        if not option.rule:
            opt = np.array(r.prep.options)
            opt[abi.OPT[option.name]] = -3.0
            assert r.init(opt=opt) == S["ok"], option.name


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_each_nonfinite_parameter_is_named(value):
    r = Raw(_scene())
    assert r.set_law() == S["ok"]
    for k, name in enumerate(abi.names(abi.PARAMETERS)):
        prm = np.array(r.prep.parameters)
        prm[k] = value
        assert r.init(prm=prm) == S["bad_parameters"], name
        assert (r.c.crt_bad_parameter(r.s), r.c.crt_bad_option(r.s)) == (k, -1), name


@pytest.mark.parametrize("code", [-1.0, 0.5, float(len(shapes.SHAPES)), 1e9])
def test_a_shape_code_that_names_no_surface_is_a_bad_parameter(code):
    r = Raw(_scene())
    assert r.set_law() == S["ok"]
    prm = np.array(r.prep.parameters)
    prm[abi.PRM["shape"]] = code
    assert r.init(prm=prm) == S["bad_parameters"]
    assert r.c.crt_bad_parameter(r.s) == abi.PRM["shape"]
    for ok in range(len(shapes.SHAPES)):              # every registered code is taken
        prm[abi.PRM["shape"]] = float(ok)
        assert r.init(prm=prm) == S["ok"]


def test_a_nonfinite_initial_state_is_nonfinite():
    r = Raw(_scene())
    assert r.set_law() == S["ok"]
    r.prep.start.q0[0] = math.nan
    try:
        assert r.init() == S["nonfinite"]
    finally:
        r.prep.start.q0[0] = prepare(_scene()).start.q0[0]


# ---- names ---------------------------------------------------------------------------------
def test_status_names_agree_with_abi_for_every_code():
    lib = library("vertical").lib
    codes = [s.code for s in abi.STATUSES]
    assert len(set(codes)) == len(codes) and len(set(S)) == len(S)
    assert S["ok"] == 0 and all(S[n] > 0 for n in ("paused", "done", "max_events"))
    assert all(S[n] < 0 for n in ("max_steps", "step_underflow", "nonfinite", "penetration",
                                  "bad_argument", "bad_options", "bad_parameters",
                                  "bad_law"))
    for code in range(min(codes) - 5, max(codes) + 6):
        want = abi.status_name(code) if code in codes else ""
        assert lib.crt_status_name(code).decode() == want, code
    header = (GENERATED / "runtime" / "crt_abi.h").read_text()
    enum = header[header.index("enum crt_status {"):]
    enum = enum[:enum.index("};")]
    got = {m[1].lower(): int(m[2]) for m in re.finditer(r"\bCRT_(\w+) = (-?\d+)", enum)}
    assert got == S


def test_the_manual_lists_every_code():
    """crt_core.h's header comment (the runtime's manual, written by hand) lists every
    return code with its value, as abi.py has it."""
    text = (GENERATED / "runtime" / "crt_core.h").read_text()
    manual = text[text.index("---- Return codes"):text.index("---- The model")]
    got = {m[1].lower(): int(m[2])
           for m in re.finditer(r"^ \*   CRT_(\w+) +(-?\d+) ", manual, re.M)}
    assert got == S


def test_a_run_stops_after_exactly_max_steps_steps():
    """max_steps = 100 on the ball falling from 100 m by RK4 steps of 1 ms (no impact in
    0.1 s): the status is max_steps after exactly 100 steps, a row each, the last at
    t = 0.1 s and on the free fall's parabola (a count 5 % short or over, 96 or 105,
    would show)."""
    step, n, z0 = 1e-3, 100, 100.0
    prep = prepare(ball(e=0.5, z0=z0, duration=1.0, method="rk4", step=step))
    opt = np.array(prep.options, dtype=float)
    opt[[o.name for o in abi.OPTIONS].index("max_steps")] = n
    session = Session(prep.library)
    session.set_law(prep.scene.law)
    raw = session.run(0.0, 1.0, prep.start.q0, opt, prep.parameters)
    assert raw.status == "max_steps" and raw.stats["steps"] == n
    assert len(raw.t) == n + 1
    np.testing.assert_allclose(raw.t, step * np.arange(n + 1), rtol=0, atol=1e-15)
    # (Z_C, Z_C') of the vertical model
    assert raw.q.shape[1] == 2
    np.testing.assert_allclose(raw.q[-1], [z0 - 0.5 * 9.81 * raw.t[-1] ** 2, -9.81 * raw.t[-1]],
                               rtol=0, atol=1e-12)


def test_a_first_step_whose_stages_overflow_is_retried_not_a_nonfinite_stop():
    """A torque-free body (no plane, g = 0, the point fixed at its centre of mass) spins
    at 300 rad/s near its intermediate axis; DOP853's first step is asked to be 1 s long
    (h0 = hmax = 1 through the options: 48 turns in one step), whose stages overflow to
    inf: the step is retried a quarter as long until it is finite, then held to the error
    control, and the run ends done (a non-finite step is the status nonfinite only at the
    least step), in one call: a refused step is retried within it, never a pause (which
    is a full buffer's alone).  The torque-free invariants, 2 T = w.J w and |J w|, are the
    start's to 1e-9 at the end."""
    O = [o.name for o in abi.OPTIONS]
    J = np.array([0.1, 0.2, 0.3])
    doc = {"name": "spin", "body": {"mass": 1.0, "inertia": J.tolist(), "shape": "none"},
           "point": {"mass": 0.5, "law": ["0", "0", "0"]},
           "initial": {"omega": [0.1, 300.0, 0.1]},
           "run": {"duration": 1.0, "g": 0.0, "method": "dop853"}}
    prep = prepare(doc)
    opt = np.array(prep.options, dtype=float)
    opt[O.index("h0")] = opt[O.index("hmax")] = 1.0
    session = Session(prep.library)
    session.set_law(prep.scene.law)
    pauses = []
    raw = session.run(0.0, 1.0, prep.start.q0, opt, prep.parameters, progress=pauses.append)
    assert raw.status == "done" and raw.stats["rejected"] >= 1
    assert len(raw.t) + abi.MIN_ROWS <= session.chunk and pauses == [1.0]
    w0, w1 = raw.q[0, 6:9], raw.q[-1, 6:9]
    assert abs(w1 @ (J * w1) / (w0 @ (J * w0)) - 1) < 1e-9
    assert abs(np.linalg.norm(J * w1) / np.linalg.norm(J * w0) - 1) < 1e-9


# ---- crt_core.h's own rules at their edges (mutants of its checks: issue 36) -------------
def test_each_restitution_model_code_is_taken_and_the_next_refused():
    """Codes 0 .. count - 1 of abi.RESTITUTION_MODELS are taken; the count itself, a
    fraction and -1 are the parameter restitution_model (a bound loosened by 5 % took the
    count)."""
    r = Raw(_scene())
    assert r.set_law() == S["ok"]
    prm = np.array(r.prep.parameters)
    k = abi.PRM["restitution_model"]
    for ok in range(len(abi.RESTITUTION_MODELS)):
        prm[k] = float(ok)
        assert r.init(prm=prm) == S["ok"], ok
    for bad in (float(len(abi.RESTITUTION_MODELS)), 0.5, -1.0):
        prm[k] = bad
        assert r.init(prm=prm) == S["bad_parameters"], bad
        assert r.c.crt_bad_parameter(r.s) == k


def _table(r, knots, coef, periodic):
    r.knots = np.ascontiguousarray(knots, dtype=float)
    r.coef = np.ascontiguousarray(coef, dtype=float)
    return r.c.crt_set_law_table(r.s, len(r.knots), r.knots.ctypes.data_as(DP),
                                 r.coef.ctypes.data_as(DP), periodic)


def _rows(r, t):
    t = np.ascontiguousarray(t, dtype=float)
    u = np.full((len(t), 9), -7.0)
    r.c.crt_law_rows(r.s, len(t), t.ctypes.data_as(DP), u.ctypes.data_as(DP))
    return u


def test_a_table_law_needs_knots_increasing_however_close():
    """Knots 2 % apart are taken, knots 2 % back refused (crt_set_law_table: a factor of
    1.05 either side of its comparison turned one into the other)."""
    r = Raw(_scene())
    coef = np.zeros(12)
    assert _table(r, [1.0, 1.02], coef, 0) == S["ok"]
    assert _table(r, [1.0, 0.98], coef, 0) == S["bad_law"]
    assert _table(r, [-1.0, -1.02], coef, 0) == S["bad_law"]
    assert _table(r, [-1.0, -0.98], coef, 0) == S["ok"]


def test_a_periodic_table_repeats_and_a_plain_one_does_not():
    """x = s on one interval [0, 1] (s = t - 0: c2 = 1), read by crt_law_rows at 1.25:
    0.25 when periodic (the period 1), else the piece's own 1.25 (extended); x' = 1 both."""
    r = Raw(_scene())
    coef = np.zeros(12)
    coef[2] = 1.0                                  # x = 0 s^3 + 0 s^2 + 1 s + 0
    assert _table(r, [0.0, 1.0], coef, 1) == S["ok"]
    u = _rows(r, [0.5, 1.25])
    assert u[0, 0] == pytest.approx(0.5, abs=1e-15) and u[1, 0] == pytest.approx(0.25, abs=1e-15)
    assert u[1, 3] == pytest.approx(1.0, abs=1e-15)
    assert _table(r, [0.0, 1.0], coef, 0) == S["ok"]
    assert _rows(r, [1.25])[0, 0] != pytest.approx(0.25, abs=1e-3)


def test_a_first_step_given_is_the_first_step_taken():
    """opt h0 > 0 is the first step of an adaptive run (the first row after t0 is at
    t0 + h0); h0 = 0 lets the runtime choose (crt_init's rule)."""
    r = Raw(_scene())
    assert r.set_law() == S["ok"]
    opt = np.array(r.prep.options)
    assert int(opt[abi.OPT["method"]]) != abi.index(abi.METHODS, "rk4")
    h0 = 3.7e-6
    opt[abi.OPT["h0"]] = h0
    assert r.init(opt=opt) == S["ok"]
    r.advance(64, 64)
    t0 = float(r.prep.scene.t0)
    assert r.n.value >= 2 and r.t[1] - t0 == pytest.approx(h0, rel=1e-12)
    opt[abi.OPT["h0"]] = 0.0
    assert r.init(opt=opt) == S["ok"]
    r.advance(64, 64)
    assert abs(r.t[1] - t0 - h0) > 1e-3 * h0

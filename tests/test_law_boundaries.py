"""crt_law.h on its own (the runtime's law: programs, tables, laws of several bodies, a
controller's law over them, the next knot), compiled with a small shim and called
directly, where its decisions sit: at the knots and 1e-9 either side, before the first
knot and past the last, across periods (negative times and tables that start far from
0, so that a comparison 5 % off moves a time across several knots), at the margin of the
next knot, and at each rule of a program.  Each answer against something computed
apart:

* programs: value and two derivatives against SymPy's differentiation of the text;
* tables: coefficients drawn at random, each interval its own cubic (no continuity to
  hide a wrong interval), against the piece that holds t by construction (the interval
  an offset was drawn in, the period added afterwards);
* the next knot: against the knots as listed, periods added;
* the rules of a program and of a law of several bodies: a valid case accepted and each
  rule broken by one step refused (the rules as the header states them).

About a second: one shim build (cached by content), no model.
"""
from __future__ import annotations

import ctypes

import numpy as np
import pytest
import sympy as sp

from derive import abi
from derive.cbuild import build_shared, runtime_flags
from derive.paths import c_sources
from derive.scene.law import compile_law

SHIM = r"""
#include "crt_law.h"
int shim_law_size(void) { return (int)sizeof(crt_law); }
int shim_work_size(void) { return (int)sizeof(crt_law_work); }
int shim_program_ok(int n_nodes, int n_const, const int *code, int n_consts)
{ return crt_law_program_ok(n_nodes, n_const, code, n_consts); }
int shim_set_bodies(crt_law *L, crt_law_work *w, int n_points, int n_rotors,
                    const int *out, int n_nodes, int n_const, const int *code,
                    const double *consts, int n_consts, int n_knots, int n_columns,
                    const double *knots, const double *coef, int periodic)
{ return crt_law_set_bodies(L, w, n_points, n_rotors, out, n_nodes, n_const, code, consts,
                            n_consts, n_knots, n_columns, knots, coef, periodic); }
void shim_set_program(crt_law *L, crt_law_work *w, int n_nodes, int n_const,
                      const int *code, const double *consts, const int *out)
{
  int k;
  L->kind = CRT_LAW_PROGRAM; L->n_points = 1; L->n_rotors = 0;
  L->n_nodes = n_nodes; L->n_const = n_const; L->code = code; L->consts = consts;
  for (k = 0; k < 3; ++k) L->out[k] = out[k];
  L->extend = 0; L->ctl_n_knots = 0;
  crt_law_prepare(L, w);
}
void shim_set_table(crt_law *L, crt_law_work *w, int n_knots, const double *knots,
                    const double *coef, int periodic)
{
  L->kind = CRT_LAW_TABLE; L->n_points = 1; L->n_rotors = 0; L->n_nodes = 0;
  L->n_knots = n_knots; L->n_columns = 3; L->knots = knots; L->coef = coef;
  L->periodic = periodic; L->extend = 0; L->ctl_n_knots = 0;
  crt_law_prepare(L, w);
}
void shim_set_control(crt_law *L, int n_knots, const double *knots, const double *coef,
                      const int *out)
{
  int c;
  L->ctl_n_knots = n_knots; L->ctl_knots = knots; L->ctl_coef = coef;
  for (c = 0; c < 3; ++c) L->ctl_out[c] = out[c];
}
int shim_width(const crt_law *L) { return crt_law_u_width(L); }
long shim_eval(const crt_law *L, crt_law_work *w, int n, const double *ts, double *u)
{
  long count = 0;
  int k, i;
  const int width = crt_law_u_width(L);
  for (k = 0; k < n; ++k) {
    const double *v = crt_law_eval(L, w, ts[k], &count);
    for (i = 0; i < width; ++i) u[width * k + i] = v[i];
  }
  return count;
}
void shim_next_knot(const crt_law *L, int n, const double *ts, double *out)
{
  int k;
  for (k = 0; k < n; ++k) out[k] = crt_law_next_knot(L, ts[k]);
}
"""

DP = ctypes.POINTER(ctypes.c_double)
IP = ctypes.POINTER(ctypes.c_int)
OP = abi.OP


@pytest.fixture(scope="module")
def lib():
    here = c_sources("runtime")
    sources = {"shim.c": SHIM}
    for name in ("crt_law.h", "crt_abi.h", "crt_math.h", "crt_constants.h"):
        sources[name] = (here / name).read_text(encoding="utf-8")
    return ctypes.CDLL(str(build_shared(sources, flags=runtime_flags(), name="lawshim")))


class Law:
    """A crt_law and its workspace in fresh (zeroed) memory, and the arrays they point to
    kept alive."""

    def __init__(self, lib):
        self.lib = lib
        self.L = ctypes.create_string_buffer(lib.shim_law_size())
        self.w = ctypes.create_string_buffer(lib.shim_work_size())
        self.keep = []

    def p(self, a, kind=float):
        a = np.ascontiguousarray(a, dtype=np.float64 if kind is float else np.int32)
        self.keep.append(a)
        return a.ctypes.data_as(DP if kind is float else IP)

    def eval(self, ts):
        ts = np.ascontiguousarray(ts, dtype=float)
        width = self.lib.shim_width(self.L)
        u = np.zeros((len(ts), width))
        self.lib.shim_eval.restype = ctypes.c_long
        self.lib.shim_eval(self.L, self.w, len(ts), ts.ctypes.data_as(DP), u.ctypes.data_as(DP))
        return u

    def next_knot(self, ts):
        ts = np.ascontiguousarray(ts, dtype=float)
        out = np.zeros(len(ts))
        self.lib.shim_next_knot(self.L, len(ts), ts.ctypes.data_as(DP), out.ctypes.data_as(DP))
        return out


# ---- programs ---------------------------------------------------------------------------
TEXTS = (("0.3*sin(2*t + 0.5) + 0.2*cos(3*t)",
          "sin(t^2) + 2*t*cos(t^2) + t^2*tan(0.3*t) - sin(t)",
          "exp(-0.5*t)*log(2 + t) + sqrt(1 + t^2)"),
         ("sinh(0.5*t) - cosh(0.2*t) + tanh(t - 1)", "asin(0.3*sin(t)) + acos(0.2*cos(t))",
          "atan(t - 1) + (1 + t^2)^1.5 + (2 + t)^(0.5*sin(t)) - t^3/(3 + t)"))
OPS_OF = {TEXTS[0]: ("hsin", "hcos", "sin", "cos", "tan", "exp", "log", "sqrt", "powi", "mul",
                     "add", "sub"),
          TEXTS[1]: ("sinh", "cosh", "tanh", "asin", "acos", "atan", "powr", "pow", "div")}


@pytest.mark.parametrize("texts", TEXTS)
def test_a_programs_value_and_two_derivatives_are_sympys(lib, texts):
    """Every operation of the interpreter (the sine and cosine of one argument shared, the
    harmonics A sin|cos(w t + p)): u = (x, y, z, x', y', z', x'', y'', z'') against SymPy's
    derivatives of the texts, at times either side of 0, the same time twice (the last
    evaluation reused: the count says so)."""
    prog = compile_law(texts)
    ar = prog.arrays()
    law = Law(lib)
    lib.shim_set_program(law.L, law.w, len(ar["code"]), ar["n_const"], law.p(ar["code"], int),
                         law.p(ar["consts"]), law.p(ar["outputs"], int))
    assert lib.shim_width(law.L) == 9
    ts = np.array([-0.7, 0.0, 0.4, 0.4, 1.3, 2.9])
    got = law.eval(ts)
    t = sp.Symbol("t", real=True)
    for c, text in enumerate(texts):
        f = sp.sympify(text.replace("^", "**"), locals={"t": t})
        for d in range(3):
            df = sp.diff(f, t, d)
            want = np.array([float(df.subs(t, float(v)).evalf(30)) for v in ts])
            assert np.max(np.abs(got[:, 3 * d + c] - want) / (1 + np.abs(want))) < 1e-12, \
                (text, d, got[:, 3 * d + c], want)
    used = {int(op) for op in ar["code"][:, 0]}
    assert used >= {OP[name] for name in OPS_OF[texts]}, sorted(used)


def test_the_rules_of_a_program(lib):
    """crt_law_program_ok as its comment states the rules: a valid program of every shape
    of node accepted; each rule broken by one step refused, and the last index each
    rule allows accepted."""
    C, T, ADD, NEG, POWI, HSIN = (OP[k] for k in ("const", "t", "add", "neg", "powi",
                                                  "hsin"))
    n_consts = 4
    good = [(C, 0, 0), (C, 3, 0), (T, 0, 0), (HSIN, 1, 0), (ADD, 2, 3), (NEG, 4, 0),
            (POWI, 5, 3), (OP["pow"], 6, 1), (OP["sin"], 7, 0)]

    def ok(rows, n_const=2, n_nodes=None, nc=n_consts):
        code = np.ascontiguousarray(np.array(rows, dtype=np.int32).reshape(-1, 3))
        n = len(rows) if n_nodes is None else n_nodes
        return lib.shim_program_ok(n, n_const, code.ctypes.data_as(IP), nc)

    assert ok(good) == 1
    assert ok(good[:1], n_const=1) == 1                    # one node
    assert ok([(T, 0, 0)], n_const=0) == 1                 # no constant

    def with_row(k, row):
        rows = list(good)
        rows[k] = row
        return rows
    refused = {
        "no node": (good, 2, 0),
        "more nodes than the workspace": (good * 120, 2, abi.LAW_MAX_NODES + 1),
        "a negative count of constants": (good, -1, None),
        "more constants than nodes": (good[:2], 3, None),
        "an op below 0": (with_row(2, (-1, 0, 0)), 2, None),
        "an op past the last": (with_row(2, (OP["hcos"] + 1, 0, 0)), 2, None),
        "a constant after the constants": (with_row(2, (C, 0, 0)), 2, None),
        "an operation among the constants": (with_row(1, (T, 0, 0)), 2, None),
        "a constant index below 0": (with_row(1, (C, -1, 0)), 2, None),
        "a constant index past the constants": (with_row(1, (C, n_consts, 0)), 2, None),
        "a harmonic's index below 0": (with_row(3, (HSIN, -1, 0)), 2, None),
        "a harmonic past the constants": (with_row(3, (OP["hcos"], n_consts - 2, 0)), 2,
                                          None),
        "an argument below 0": (with_row(5, (NEG, -1, 0)), 2, None),
        "an argument reading itself": (with_row(5, (NEG, 5, 0)), 2, None),
        "a power's exponent index below 0": (with_row(6, (POWI, 5, -1)), 2, None),
        "a power's exponent past the constants": (with_row(6, (OP["powr"], 5, n_consts)), 2,
                                                  None),
        "a second argument below 0": (with_row(4, (OP["sub"], 2, -1)), 2, None),
        "a second argument reading itself": (with_row(4, (OP["mul"], 2, 4)), 2, None),
        "a divisor reading itself": (with_row(4, (OP["div"], 2, 4)), 2, None),
        "an exponent node reading itself": (with_row(7, (OP["pow"], 6, 7)), 2, None),
        "a sum reading a later node": (with_row(4, (ADD, 2, 5)), 2, None),
    }
    for name, (rows, n_const, n_nodes) in refused.items():
        nn = n_nodes if n_nodes is not None else len(rows)
        rows = rows if len(rows) >= max(nn, 1) else rows + [(T, 0, 0)] * (nn - len(rows))
        assert ok(rows, n_const, nn) == 0, name
    # the last index each rule allows
    allowed = {
        "the last constant": with_row(1, (C, n_consts - 1, 0)),
        "a harmonic on the last three constants": with_row(3, (HSIN, n_consts - 3, 0)),
        "an argument the node just before": with_row(5, (NEG, 4, 0)),
        "an exponent the last constant": with_row(6, (POWI, 5, n_consts - 1)),
        "a second argument the node just before": with_row(4, (OP["mul"], 2, 3)),
        "the last op": with_row(3, (OP["hcos"], 1, 0)),
    }
    for name, rows in allowed.items():
        assert ok(rows) == 1, name


# ---- tables -----------------------------------------------------------------------------
def _pieces(rng, knots, columns):
    """Random cubic coefficients, each interval its own (no continuity)."""
    return rng.uniform(-2.0, 2.0, (len(knots) - 1, columns, 4))


def _expected(coef, knots, i, s):
    """(columns, 3): value, first and second derivative of piece i at s."""
    c = coef[i]
    x = ((c[:, 0] * s + c[:, 1]) * s + c[:, 2]) * s + c[:, 3]
    dx = (3 * c[:, 0] * s + 2 * c[:, 1]) * s + c[:, 2]
    return np.stack([x, dx, 6 * c[:, 0] * s + 2 * c[:, 1]], axis=1)


def _cases(knots, periodic):
    """(t, interval, s) by construction: at each knot and 1e-9 either side, mid-interval,
    before the first knot and past the last; for a periodic table the same offsets moved
    by whole periods either way."""
    t0, t1 = knots[0], knots[-1]
    n = len(knots)
    out = []
    for i in range(n - 1):
        for s in (0.0, 1e-9, 0.5 * (knots[i + 1] - knots[i]), knots[i + 1] - knots[i] - 1e-9):
            out.append((knots[i] + s, i, s))
    if periodic:
        span = t1 - t0
        # (of the knots themselves only the first: wrapped into the period, t0 + fmod(t -
        # t0, span) may round to either side of a later one, and these pieces do not join)
        out = [(t + k * span, i, s) for (t, i, s) in out for k in (-3, -1, 0, 1, 2)
               if s != 0.0 or (i == 0 and k == 0)]
        out.append((t1, 0, 0.0))
    else:
        out += [(t0 - 1e-9, 0, 0.0), (t0 - 0.3 * (t1 - t0), 0, 0.0),
                (t1, n - 2, t1 - knots[-2]), (t1 + 1e-9, n - 2, t1 - knots[-2]),
                (t1 + 0.3 * (t1 - t0), n - 2, t1 - knots[-2])]
    return out


KNOT_SETS = {"far from 0": 5.0 + np.cumsum(np.r_[0.0, np.linspace(0.04, 0.07, 9)]),
             "negative": -3.0 + np.cumsum(np.r_[0.0, np.linspace(0.05, 0.03, 8)]),
             "across 0": np.array([-0.6, -0.2, -0.05, 0.1, 0.3, 0.8])}


@pytest.mark.parametrize("periodic", [0, 1])
@pytest.mark.parametrize("which", list(KNOT_SETS))
def test_a_table_evaluates_the_piece_that_holds_t(lib, which, periodic):
    """A table law (crt_law_table) at the cases of _cases, in three orders (ascending,
    descending, shuffled: the interval kept from the last call is right or found
    again): each the piece that holds t by construction, to rounding."""
    rng = np.random.default_rng(len(which) + 10 * periodic)
    knots = KNOT_SETS[which]
    coef = _pieces(rng, knots, 3)
    law = Law(lib)
    lib.shim_set_table(law.L, law.w, len(knots), law.p(knots), law.p(coef.ravel()), periodic)
    assert lib.shim_width(law.L) == 9
    cases = _cases(knots, periodic)
    order = np.argsort([c[0] for c in cases])
    for idx in (order, order[::-1], rng.permutation(len(cases))):
        ts = np.array([cases[k][0] for k in idx])
        got = law.eval(ts)
        for row, k in zip(got, idx):
            t, i, s = cases[k]
            want = _expected(coef, knots, i, s)           # (3 columns, 3 derivatives)
            err = np.abs(row.reshape(3, 3).T - want)
            assert np.max(err) < 1e-12 * (1 + abs(t)) * 50, (which, t, i, s)


def test_a_law_of_bodies_puts_each_output_and_the_controllers_where_they_belong(lib):
    """crt_law_set_bodies with two points and two rotors, outputs from a program's nodes
    and from columns of a periodic table on knots far from 0, and a controller's law
    over three outputs (a point's coordinate, a rotor, and one slot unused; held at its
    first knot before it, its last cubic going on past its end): each number of u in its
    slot (point j at 9 j + 3 d + c, rotor r at 18 + 3 r + d) against the pieces by
    construction and SymPy."""
    rng = np.random.default_rng(3)
    texts = ("0.3*sin(2*t + 0.5)", "0.1*t^2", "cos(t)*sin(t)")
    prog = compile_law(texts)
    ar = prog.arrays()
    nodes = [int(o) for o in ar["outputs"]]
    knots = KNOT_SETS["far from 0"]
    coef = _pieces(rng, knots, 4)                         # 4 columns
    # outputs: point 0 (x, y, z) = (column 2, node of text 0, column 0); point 1 = (node 1,
    # column 3, node 2); rotor 0 = column 1, rotor 1 = node of text 0
    out = [-3, nodes[0], -1, nodes[1], -4, nodes[2], -2, nodes[0]]
    law = Law(lib)
    assert lib.shim_set_bodies(law.L, law.w, 2, 2, law.p(out, int), len(ar["code"]),
                               ar["n_const"], law.p(ar["code"], int), law.p(ar["consts"]),
                               len(ar["consts"]), len(knots), 4, law.p(knots),
                               law.p(coef.ravel()), 1) == 0           # CRT_OK
    assert lib.shim_width(law.L) == 24
    ck = np.array([5.1, 5.15, 5.3])
    ccoef = _pieces(rng, ck, 3)
    ctl_out = [4, -1, 7]                                  # point 1's y, none, rotor 1
    lib.shim_set_control(law.L, len(ck), law.p(ck), law.p(ccoef.ravel()), law.p(ctl_out, int))
    t = sp.Symbol("t", real=True)
    fs = [sp.sympify(x.replace("^", "**"), locals={"t": t}) for x in texts]
    dfs = [[sp.lambdify(t, sp.diff(f, t, d), "math") for d in range(3)] for f in fs]
    span = knots[-1] - knots[0]
    cases = [(tt + k * span, i, s) for (tt, i, s) in _cases(knots, 0)[:-5] for k in (0, 1)]
    ctl_cases = {5.0: (0, 0.0), 5.1 - 1e-9: (0, 0.0), 5.1: (0, 0.0), 5.15 - 1e-9: (0, 0.05 - 1e-9),
                 5.15: (1, 0.0), 5.3: (1, 0.15), 5.3 + 1e-9: (1, 0.15 + 1e-9), 5.6: (1, 0.45)}
    ts = np.array([c[0] for c in cases] + list(ctl_cases))
    got = law.eval(ts)

    def ctl_jet(c, tt):
        """the controller's column c: held at its first knot before it, its last cubic
        going on past its end"""
        if tt in ctl_cases:
            i, s = ctl_cases[tt]
        else:
            i = min(max(np.searchsorted(ck, tt, side="right") - 1, 0), len(ck) - 2)
            s = max(tt - ck[i], 0.0)
        return _expected(ccoef, ck, i, s)[c]

    def jet_of(src, tt):
        if src >= 0:
            return np.array([float(df(tt)) for df in dfs[nodes.index(src)]])
        tw = knots[0] + np.mod(tt - knots[0], span)
        i = min(np.searchsorted(knots, tw, side="right") - 1, len(knots) - 2)
        return _expected(coef, knots, i, tw - knots[i])[-1 - src]

    for row, tt in zip(got, ts):
        for k, src in enumerate(out):
            at, step = (9 * (k // 3) + k % 3, 3) if k < 6 else (18 + 3 * (k - 6), 1)
            want = jet_of(src, tt)
            if k in ctl_out:
                want = ctl_jet(ctl_out.index(k), tt)
            for d in range(3):
                assert abs(row[at + d * step] - want[d]) < 1e-9 * (1 + abs(want[d])), \
                    (tt, k, d, row[at + d * step], want[d])


def test_the_rules_of_a_law_of_bodies(lib):
    """crt_law_set_bodies: a valid law accepted (up to the workspace's points and
    rotors), and each rule broken by one step refused, leaving no law (width 0)."""
    prog = compile_law(("t", "2*t", "3*t"))
    ar = prog.arrays()
    nodes = [int(o) for o in ar["outputs"]]
    knots = np.array([0.0, 1.0, 1.02])

    def try_(n_points=1, n_rotors=1, out=None, n_nodes=None, n_knots=3, n_columns=2,
             kn=knots):
        law = Law(lib)
        out = out if out is not None else [nodes[0], -2, nodes[2], -1]
        out = list(out) + [0] * (3 * 16 + 8 - len(out))
        r = lib.shim_set_bodies(law.L, law.w, n_points, n_rotors, law.p(out, int),
                                len(ar["code"]) if n_nodes is None else n_nodes,
                                ar["n_const"], law.p(ar["code"], int), law.p(ar["consts"]),
                                len(ar["consts"]), n_knots, n_columns, law.p(kn),
                                law.p(np.zeros(4 * 4 * max(n_columns, 1) * 3)), 0)
        return r, lib.shim_width(law.L)

    ok, width = try_()
    assert width == 12
    assert try_(n_points=16, n_rotors=8, out=[nodes[0]] * 56) == (ok, 9 * 16 + 3 * 8)
    assert try_(n_points=0, n_rotors=1, out=[nodes[0]]) == (ok, 3)
    assert try_(out=[nodes[0], nodes[1], nodes[2], nodes[0]], n_knots=0) == (ok, 12)
    assert try_(out=[-1, -2, -1, -2], n_nodes=0) == (ok, 12)
    broken = {"points below 0": dict(n_points=-1), "points past the workspace":
              dict(n_points=17), "rotors below 0": dict(n_rotors=-1),
              "rotors past the workspace": dict(n_rotors=9),
              "one knot": dict(n_knots=1), "no column": dict(n_columns=0),
              "columns past the outputs": dict(n_columns=3 * 16 + 8 + 1),
              "knots not increasing": dict(kn=np.array([0.0, 1.0, 0.98])),
              "knots repeated": dict(kn=np.array([0.0, 1.0, 1.0])),
              "negative knots not increasing": dict(kn=np.array([-1.0, -0.98, -0.99])),
              "an output past the nodes": dict(out=[len(ar["code"]), -1, -1, -1]),
              "an output past the columns": dict(out=[-3, -1, -1, -1]),
              "a column without a table": dict(out=[-1, nodes[0], nodes[0], nodes[0]],
                                               n_knots=0),
              "a node without a program": dict(out=[nodes[0], -1, -1, -1], n_nodes=0),
              "a malformed program": dict(n_nodes=len(ar["code"]) + 1)}
    for name, change in broken.items():
        r, width = try_(**change)
        assert r != ok and width == 0, name
    assert try_(kn=np.array([-1.0, -0.99, -0.98]))[0] == ok


# ---- the next knot ----------------------------------------------------------------------
@pytest.mark.parametrize("periodic", [0, 1])
@pytest.mark.parametrize("which", ["far from 0", "negative"])
def test_the_next_knot_is_the_first_past_t_and_its_margin(lib, which, periodic):
    """crt_law_next_knot of a table: at each knot (the next one), 1e-9 before it (this
    one), within the margin 1e-12 (|t| + span) before it (the next: counted as reached)
    and at twice the margin (this one); before the first knot the first; past the last
    +inf, or, periodic, the knots of the next period.  Then a controller's law over a
    law of bodies adds its knots (their own margins)."""
    knots = KNOT_SETS[which]
    span = knots[-1] - knots[0]
    law = Law(lib)
    coef = np.zeros((len(knots) - 1) * 12)
    lib.shim_set_table(law.L, law.w, len(knots), law.p(knots), law.p(coef), periodic)
    shifts = (0, -2, 1, 3) if periodic else (0,)
    ts, want = [], []
    for k in shifts:
        base = k * span
        for i, kn in enumerate(knots[:-1]):
            t = kn + base
            margin = 1e-12 * (abs(t) + span)
            nxt = knots[i + 1] + base
            for tt, w in ((t, nxt), (t - 1e-9, t), (t - 0.5 * margin, nxt),
                          (t - 2 * margin, t)):
                ts.append(tt)
                want.append(w)
        last = knots[-1] + base - 1e-9
        ts.append(last)
        want.append(knots[-1] + base)
    if periodic:
        ts += [knots[-1], knots[-1] + 0.01]
        want += [knots[1] + span] * 2
    else:
        ts += [knots[0] - 1e-9, knots[0] - 0.3 * span, knots[-1], knots[-1] + 0.3 * span]
        want += [knots[0], knots[0], np.inf, np.inf]
    got = law.next_knot(ts)
    bad = [(t, g, w) for t, g, w in zip(ts, got, want)
           if not (g == w or abs(g - w) <= 1e-12 * (1 + abs(w)))]
    assert not bad, bad[:5]


def test_a_controllers_knots_join_the_next_knot_of_a_law_of_bodies(lib):
    """A law of bodies with a table (knots 0 .. 1) and a controller's law on knots far
    from 0 and from the table's: the next knot is the nearer of the two, the
    controller's held before its first knot and none past its last."""
    prog = compile_law(("t", "t", "t"))
    ar = prog.arrays()
    knots = np.array([0.0, 0.25, 0.5, 1.0])
    law = Law(lib)
    out = [-1, -1, -1]
    assert lib.shim_set_bodies(law.L, law.w, 1, 0, law.p(out, int), len(ar["code"]),
                               ar["n_const"], law.p(ar["code"], int), law.p(ar["consts"]),
                               len(ar["consts"]), len(knots), 1, law.p(knots),
                               law.p(np.zeros(12)), 0) == 0
    ck = np.array([0.6, 0.62, 0.7, 0.8, 0.9])
    lib.shim_set_control(law.L, len(ck), law.p(ck), law.p(np.zeros(12 * (len(ck) - 1))),
                         law.p([0, -1, -1], int))

    def m(t):                  # the controller's knots' margin at t
        return 1e-12 * (abs(t) + ck[-1] - ck[0])
    cases = {0.1: 0.25, 0.3: 0.5, 0.55: 0.6, 0.6 - 1e-9: 0.6, 0.6 - 0.5 * m(0.6): 0.62,
             0.6 - 2 * m(0.6): 0.6, 0.6: 0.62, 0.63: 0.7, 0.62 - 0.5 * m(0.62): 0.7,
             0.62 - 2 * m(0.62): 0.62, 0.75: 0.8, 0.8 - 0.5 * m(0.8): 0.9,
             0.8 - 2 * m(0.8): 0.8, 0.9 - 1e-9: 0.9, 0.9 - 0.5 * m(0.9): 1.0,
             0.9 - 2 * m(0.9): 0.9, 0.9: 1.0, 0.95: 1.0, 1.0: np.inf, 1.3: np.inf}
    got = law.next_knot(list(cases))
    assert list(got) == list(cases.values()), list(zip(cases, got))

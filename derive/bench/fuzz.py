"""Hostile scene input: a seeded fuzzer for the scene parser and ``derive simulate``.

Scene files come from strangers.  This module generates, from a seed, three families of
hostile input and judges what the toolkit does with each (written from the README's
contract, not from the parser's code):

* ``scene``: mutations of valid scenes: wrong types, NaN and infinities, huge, tiny and
  negative numbers, big integers, missing and extra keys, wrong list shapes, hostile
  strings (C/Python/shell injection, control characters, unicode digits and spaces, very
  long text) in every string field, deep nesting;
* ``law``: random law strings from the README's grammar (numbers, ``t``, ``pi``,
  ``+ - * / ** ^``, parentheses, 13 functions) with planted poles and non-smooth points,
  and hostile tokens; an accepted law is checked against an independent evaluator of
  its value and first two derivatives on the run;
* ``table``: tabulated laws (``[point] table = "file.csv"`` or ``samples``) with paths
  that climb out (``..``, absolute, symlinks, FIFOs, devices) and huge, ragged or
  non-numeric files;
* ``toml``: text the TOML reader itself must survive (deep arrays, bad bytes, size).

Each case runs in a forked worker (``mode="api"``: ``parse_scene`` and, if accepted, the
simulation) or through the command line (``mode="cli"``: ``derive simulate`` in a
subprocess with a private HOME and working folder).  The outcome is one of

    ran-ok, ran-status (accepted; ended max_steps, ... honestly), refused (exit 2, one line,
    the field named), and the BAD ones: traceback, crash, hang, silent-accept (a scene
    the README says must be refused ran), wrong-field (refused, but blaming another
    field or none), multi-line, wrong-exit, warning, wrong-answer (rows off the true
    trajectory, law values off the expression, a status that lies), wrote-files (an
    output folder after a refusal), outside-files (anything created outside it).

``run(n, seed, mode)`` returns the outcomes and ``report(outcomes)`` a table;
``derive bench fuzz`` runs the full set.
"""
from __future__ import annotations

import copy
import math
import multiprocessing
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

PARSE_LIMIT_S = 2.0        # validation must take milliseconds; this is the hang verdict
RUN_LIMIT_S = 20.0         # a 1 s scene runs in milliseconds
CLI_LIMIT_S = 60.0
MEMORY_LIMIT = 3 << 30     # address space of a worker / CLI run (memory bombs)
SIZE_LIMIT = 1e3           # an accepted law keeping P within 1e3 body sizes (oracle)

BAD = ("traceback", "crash", "hang", "silent-accept", "wrong-field", "multi-line",
       "control-chars", "wrong-exit", "warning", "wrong-answer", "wrote-files",
       "outside-files", "fuzzer-error")
GOOD = ("ran-ok", "ran-status", "refused")

FIELD_RE = re.compile(r"^(\[[^\]\n]+\][^:\n]*|[^\W\d][\w.\\-]*\s?(\[\d+\])*)( \([^)]*\))?:")
CONTROL_RE = re.compile(r"[\x00-\x08\x0b-\x1f\x7f\u2028\u2029\u202a-\u202e]")


def base_scene(duration: float = 1.0) -> dict:
    """The README's scene, 1 s long (a few impacts, milliseconds to run)."""
    return {
        "name": "bouncing-ball",
        "body": {"mass": 1.0, "inertia": [0.10, 0.12, 0.14], "shape": "sphere",
                 "radius": 0.5, "center": [0.0, 0.0, 0.0]},
        "point": {"mass": 0.2, "law": ["0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"]},
        "plane": {"restitution": 0.9},
        "initial": {"time": 0.0, "com": [0.0, 0.0, 1.5], "com_velocity": [0.3, 0.0, 0.0],
                    "omega": [0.5, -0.3, 1.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
        "run": {"duration": duration, "method": "dopri5", "rtol": 1e-10, "atol": 1e-12,
                "g": 9.81, "outputs": ["pose", "impacts"]},
    }


def table_rows(n: int = 101, t1: float = 1.0) -> list:
    t = np.linspace(0.0, t1, n)
    return [[float(a), float(0.1 * math.sin(3 * a)), 0.1, float(0.05 * math.cos(2 * a))]
            for a in t]


def csv_text(rows, header: str = "t,x,y,z") -> str:
    return header + "\n" + "".join(",".join(repr(v) for v in r) + "\n" for r in rows)


# ---- the case ----------------------------------------------------------------------
@dataclass
class Case:
    index: int
    family: str                       # scene, law, table, toml, explicit
    desc: str
    doc: dict | None = None           # the scene as a dict (serialised for the CLI)
    text: str | bytes | None = None   # or as TOML text
    files: dict = field(default_factory=dict)   # name -> bytes | ("symlink", target) |
    #                                             ("fifo",) | ("dir",)
    expect: str = "either"            # refuse | either | accept
    fields: tuple | None = ()         # a refusal must name one of these (None: any line)
    laws: dict = field(default_factory=dict)    # component -> tree (the law oracle)
    window: tuple = (0.0, 1.0)
    size: float = 0.5                 # body size (the oracle's bound)
    toml_level_ok: bool = False       # the TOML reader may refuse it (nesting depth)

    def short(self) -> str:
        d = self.desc if len(self.desc) < 110 else self.desc[:100] + "...(" + \
            f"{len(self.desc)} chars)"
        return d.encode("unicode_escape").decode("ascii")


@dataclass
class Outcome:
    case: Case
    verdict: str
    detail: str = ""
    seconds: float = 0.0
    message: str = ""

    @property
    def bad(self) -> bool:
        return self.verdict in BAD


# ---- laws: trees, text and an independent evaluator ---------------------------------
FUNCS = ("sin", "cos", "tan", "exp", "log", "sqrt", "sinh", "cosh", "tanh", "asin", "acos",
         "atan")


def law_text(node) -> str:
    kind = node[0]
    if kind == "num":
        return f"({node[2]})" if node[2].startswith("-") else node[2]
    if kind == "t":
        return "t"
    if kind == "pi":
        return "pi"
    if kind == "neg":
        return f"(-{law_text(node[1])})"
    if kind == "fn":
        return f"{node[1]}({law_text(node[2])})"
    op = {"add": "+", "sub": "-", "mul": "*", "div": "/", "pow": "**", "hat": "^"}[kind]
    return f"({law_text(node[1])}{op}{law_text(node[2])})"


def jets(node, t: np.ndarray):
    """(f, f', f'') of a law tree at the times t, by forward differentiation."""
    kind = node[0]
    z = np.zeros_like(t)
    if kind == "num":
        return z + node[1], z, z
    if kind == "t":
        return t.copy(), z + 1.0, z
    if kind == "pi":
        return z + math.pi, z, z
    if kind == "neg":
        a, a1, a2 = jets(node[1], t)
        return -a, -a1, -a2
    if kind == "fn":
        u, u1, u2 = jets(node[2], t)
        name = node[1]
        if name == "sin":
            f, g1, g2 = np.sin(u), np.cos(u), -np.sin(u)
        elif name == "cos":
            f, g1, g2 = np.cos(u), -np.sin(u), -np.cos(u)
        elif name == "tan":
            f = np.tan(u)
            g1 = 1 + f * f
            g2 = 2 * f * g1
        elif name == "exp":
            f = np.exp(u)
            g1 = g2 = f
        elif name == "log":
            f = np.where(u > 0, np.log(np.where(u > 0, u, 1.0)), np.nan)
            g1, g2 = 1 / u, -1 / u ** 2
        elif name == "sqrt":
            f = np.where(u >= 0, np.sqrt(np.abs(u)), np.nan)
            g1 = 0.5 / f
            g2 = -0.25 / (f * u)
        elif name == "sinh":
            f, g1, g2 = np.sinh(u), np.cosh(u), np.sinh(u)
        elif name == "cosh":
            f, g1, g2 = np.cosh(u), np.sinh(u), np.cosh(u)
        elif name == "tanh":
            f = np.tanh(u)
            g1 = 1 - f * f
            g2 = -2 * f * g1
        elif name in ("asin", "acos"):
            inside = np.abs(u) <= 1
            f = np.where(inside, np.arcsin(np.clip(u, -1, 1)), np.nan)
            s = np.sqrt(np.where(inside, 1 - u * u, np.nan))
            g1 = 1 / s
            g2 = u / s ** 3
            if name == "acos":
                f, g1, g2 = math.pi / 2 - f, -g1, -g2
        elif name == "atan":
            f = np.arctan(u)
            g1 = 1 / (1 + u * u)
            g2 = -2 * u * g1 * g1
        else:
            raise KeyError(name)
        if not (u1.any() or u2.any()):
            return f, z, z
        return f, g1 * u1, g2 * u1 * u1 + g1 * u2
    a, a1, a2 = jets(node[1], t)
    b, b1, b2 = jets(node[2], t)
    if kind == "add":
        return a + b, a1 + b1, a2 + b2
    if kind == "sub":
        return a - b, a1 - b1, a2 - b2
    if kind == "mul":
        return a * b, a1 * b + a * b1, a2 * b + 2 * a1 * b1 + a * b2
    if kind == "div":
        q = a / b
        q1 = (a1 - q * b1) / b
        q2 = (a2 - 2 * q1 * b1 - q * b2) / b
        return q, q1, q2
    if kind in ("pow", "hat"):
        if node[2][0] == "num" or (b1 == 0).all() and (b2 == 0).all():
            c = b
            ci = np.round(c)
            integer = (np.abs(c - ci) < 1e-12).all()
            if integer:
                f = a ** c
                g1 = c * a ** (c - 1)
                g2 = c * (c - 1) * a ** (c - 2)
            else:
                ok = a > 0
                f = np.where(ok, np.abs(a) ** c, np.where(a == 0, 0.0, np.nan))
                g1 = np.where(ok, c * np.abs(a) ** (c - 1), np.where(a == 0, np.inf, np.nan))
                g2 = np.where(ok, c * (c - 1) * np.abs(a) ** (c - 2),
                              np.where(a == 0, np.inf, np.nan))
            if not (a1.any() or a2.any()):
                return f, z, z
            return f, g1 * a1, g2 * a1 * a1 + g1 * a2
        # a ** b = exp(b log a)
        la = jets(("fn", "log", node[1]), t)
        lb = _mul_jets(la, (b, b1, b2))
        e = np.exp(lb[0])
        return e, e * lb[1], e * (lb[2] + lb[1] ** 2)
    raise KeyError(kind)


def _mul_jets(a, b):
    return a[0] * b[0], a[1] * b[0] + a[0] * b[1], a[2] * b[0] + 2 * a[1] * b[1] + a[0] * b[2]


def num(value: float, text: str | None = None):
    """A number node; its value is the one its text denotes."""
    if text is None:
        text = _fmt(value)
        value = float(text)
    return ("num", float(value), text)


def _fmt(v: float) -> str:
    s = f"{v:.6g}"
    return s


def random_law(rng: random.Random, depth: int = 3, amp: float = 0.2):
    """A random law tree from the grammar, scaled so that the point stays near the body
    (an ``amp *`` factor in front)."""
    def leaf():
        r = rng.random()
        if r < 0.45:
            return ("t",)
        if r < 0.55:
            return ("pi",)
        v = rng.choice([rng.uniform(0.1, 3.0), float(rng.randint(1, 5)), rng.uniform(-2, 2)])
        return num(abs(v) if rng.random() < 0.8 else v)

    def grow(d):
        if d <= 0 or rng.random() < 0.25:
            return leaf()
        r = rng.random()
        if r < 0.4:
            name = rng.choice(("sin", "cos", "sin", "cos", "exp", "tanh", "atan", "sinh",
                               "cosh", "sqrt", "log", "tan", "asin", "acos"))
            arg = grow(d - 1)
            if name in ("exp", "sinh", "cosh"):
                arg = ("mul", num(rng.uniform(0.1, 1.0)), arg)
            return ("fn", name, arg)
        if r < 0.5:
            return ("neg", grow(d - 1))
        op = rng.choice(("add", "sub", "mul", "mul", "div", "pow", "hat"))
        if op in ("pow", "hat"):
            return (op, grow(d - 1), num(rng.choice([2, 3, 0.5, 1.5, -1, 2.5])))
        return (op, grow(d - 1), grow(d - 1))
    return ("mul", num(amp * rng.uniform(0.1, 1.0)), grow(depth))


def planted_law(rng: random.Random, window: tuple):
    """A law with a pole, a branch point or a kink at a: (tree, a, inside the run)."""
    t0, t1 = window
    inside = rng.random() < 0.75
    if inside:       # off any round grid: between the validation samples
        a = t0 + (t1 - t0) * rng.uniform(0.05, 0.95) + 1.234567e-7
    else:
        a = t1 + rng.uniform(0.5, 3.0) if rng.random() < 0.5 else t0 - rng.uniform(0.5, 3)
    ta = ("sub", ("t",), num(a, repr(a)))
    at = ("sub", num(a, repr(a)), ("t",))
    kinds = [
        ("pole", ("div", num(0.001), ta)),
        ("double pole", ("div", num(0.001), ("pow", ta, num(2, "2")))),
        ("kink", ("fn", "sqrt", ("pow", ta, num(2, "2")))),
        ("kink", ("mul", num(0.01), ("pow", ("pow", ta, num(2, "2")), num(0.5, "0.5")))),
        ("C1 only", ("mul", num(0.01), ("pow", ("pow", ta, num(2, "2")), num(0.75, "0.75")))),
        ("branch", ("mul", num(0.01), ("fn", "sqrt", ta))),
        ("branch", ("mul", num(0.01), ("fn", "sqrt", at))),
        ("log", ("mul", num(0.001), ("fn", "log", ta))),
        ("log", ("mul", num(0.001), ("fn", "log", ("pow", ta, num(2, "2"))))),
        ("cube root", ("mul", num(0.01), ("pow", ta, num(1 / 3, "(1/3)")))),
        ("asin domain", ("mul", num(0.01), ("fn", "asin", ("div", ("t",), num(a, repr(a))))))
        if a > 0 else ("pole", ("div", num(0.001), ta)),
        ("exp blow-up", ("mul", num(0.001), ("fn", "exp", ("div", num(1.0), ta)))),
        ("pole", ("mul", num(0.001), ("pow", ta, num(-1, "-1")))),
        ("pole", ("div", num(0.001), ("fn", "sin", ("mul", ("pi",), ("div", ta, num(4.0)))))),
    ]
    if inside:       # tan(w t) with a pole at a = pi/(2w)
        w = math.pi / 2 / a if a > 0 else 1.0
        if a > 0:
            kinds.append(("tan pole", ("mul", num(0.001),
                                       ("fn", "tan", ("mul", num(w, repr(w)), ("t",))))))
    kind, tree = rng.choice(kinds)
    # outside the run, the asin/sqrt domains may still be violated inside: judge by oracle
    return kind, tree, a, inside


HOSTILE_LAWS = [
    # code and command injection
    '__import__("os").system("touch MARKER")', 'os.system("touch MARKER")', 't.__class__',
    '().__class__.__bases__[0]', 'lambda: 0', 'eval("1")', 'exec', '$(touch MARKER)',
    '`touch MARKER`', '"; import os; os.system("touch MARKER"); "',
    '*/ __attribute__((constructor)) static void p(void){system("touch MARKER");} /*',
    't); system("touch MARKER"); (t', '0; } int x() { return 0', '#include </dev/random>',
    '\\', '{{7*7}}', '${HOME}', '%s%n', 't\x00', 't\x1b[2J',
    # names and syntax
    'x', 'T', 'e', 'E', 'Pi', 'PI', 'tau', 'inf', 'nan', 'Infinity', 'NaN*t', 'sin', 'sin t',
    'sin(t', 't)', '', ' ', '\t', '1 2', 't t', '1..2', '1e', 'e5', '**t', 't**', 't^^2',
    't**', '[t]', '{t}', 't;1', 't # c', '"t"', "'t'", 't,t', 'sin(t,t)', 'sin()', '()',
    '0x10', '0b1', '1_000', '1j', 't if t else 1', 'not t', 't and 1', 't @ t', 't // 1',
    't % 1', 'floor(t)', 'abs(t)', 'max(t, 1)', 'pow(t, 2)', 'Sin(t)', 'SIN(t)',
    # constants that are not finite reals
    '1/0', '0/0', 'sqrt(-1)', 'log(-1)', 'log(0)', 'asin(2)', 'acos(-1.5)', '(-8)**(1/3)',
    '(-1)**0.5', '0**-1', '1e400', '-1e400', '1e999*t', '1e-400*t', '2**1024', 'exp(1000)',
    'exp(exp(exp(10)))', 'cosh(1000)', '10**10**10', '9**9**9*t', '9^9^9*t', '2**2**2**2**2',
    '10**308*10', '1e308*10', '1e300*t', '1e300*t*t',
    # unicode digits, letters and spaces
    '\uff10.1*t', '\u0660.\u0661*t', '\U0001d7ce.1*t', '0.1*t\u00a0', '0.1\u2009*t',
    '0.1*t\u200b', '\u22120.1*t', '\uff53\uff49\uff4e(t)', '\u0455in(t)', '0.1*\u0442',
    '0.1*t\u2028', '\u00b9*t', '0.1\u00b7t', '0.1\u00d7t', '0.1*t\r', '0.1*\nt', '0.1*t\n',
    '0.1*t\x0b',
]


# odd but legitimate in floats: accepted or refused, never a crash
EITHER_LAWS = ['tan(pi/2)*0', '0*log(0.5)', '(0.1)^2*t', '- -0.1*t', '+0.1*t', '.5*0.1',
               '1.e-1*t', '1E-1*t', '0.1*t**2**0.5', '((((t))))*0.1', 'sqrt(t*t+1)*0.01']


def deep_laws():
    return [
        ("50 nested sin", "0.1*" + "sin(" * 50 + "t" + ")" * 50, "either"),
        ("1000 parentheses", "(" * 1000 + "0.1*t" + ")" * 1000, "refuse"),
        ("100k parentheses", "(" * 100_000 + "t" + ")" * 100_000, "refuse"),
        ("1000 nested sin", "sin(" * 1000 + "t" + ")" * 1000, "refuse"),
        ("100 kB law", "0.001*t" + "+0.000001*t" * 9000, "refuse"),
        ("1 MB law", "0.1*t" + " " * 1_000_000, "refuse"),
        ("20000 unary minus", "-" * 20000 + "0.1*t", "refuse"),
        ("power tower", "**".join(["1.0001"] * 200) + "*t", "refuse"),
        ("long number", "0." + "1" * 100_000 + "*t", "refuse"),
        ("many terms", "+".join(["0.00001*sin(t)"] * 3000), "refuse"),
    ]


# ---- hostile strings ---------------------------------------------------------------
def hostile_strings(marker: str) -> list:
    return [
        f'*/ __attribute__((constructor)) static void pwn(void){{system("touch {marker}");}} /*',
        f'$(touch {marker})', f'`touch {marker}`', f'"; import os; os.system("touch {marker}"); "',
        f"'; touch {marker}; '", f'\\"); system("touch {marker}"); //', '\x00', '\n', '\r\n',
        '../../../../x', '/etc/passwd', '..', '.', '', ' ', 'con', 'a/b', '\u202etxt.exe',
        'A' * 100_000, '%s%n%x', '{{7*7}}', '{% include "/etc/passwd" %}', '${HOME}', '\\',
        '\U0001f642', '\u0660\u0661', '#include </dev/random>', '\x1b[2J', '-o /tmp/x',
        '<script>', 'DOPRI5', 'dopri5 ', ' dopri5', 'dopri\uff15', 'sphere\x00',
    ]


# ---- scene mutations ---------------------------------------------------------------
NUMBER_FIELDS = {      # path: rule  (pos: > 0, nonneg, unit: [0, 1], any, count)
    ("body", "mass"): "pos", ("point", "mass"): "pos", ("body", "radius"): "pos",
    ("plane", "restitution"): "unit", ("initial", "time"): "any",
    ("run", "duration"): "pos", ("run", "rtol"): "pos", ("run", "atol"): "pos",
    ("run", "g"): "any", ("run", "step"): "pos", ("run", "output_dt"): "nonneg",
    ("run", "max_events"): "count", ("run", "max_steps"): "count", ("run", "zeno_dt"): "pos",
}
VECTOR_FIELDS = {
    ("body", "inertia"): "pos", ("body", "center"): "any", ("initial", "com"): "any",
    ("initial", "com_velocity"): "any", ("initial", "omega"): "any",
    ("initial", "quaternion"): "quat",
}
ENUM_FIELDS = {("body", "shape"): ("sphere", "ellipsoid", "none"),
               ("run", "method"): ("rk4", "dopri5", "dop853"),
               ("run", "model"): ("auto", "general", "vertical", "attitude", "translational",
                                  "planar", "axisymmetric")}
RELATED = {
    "[body].mass": ["[point].mass", "[body].inertia"],
    "[point].mass": ["[body].mass", "[body].inertia"],
    "[body].inertia": ["[body].mass", "[point].mass", "[point].law"],
    "[body].radius": ["[point].law", "[initial].com", "[body].center", "[body].shape"],
    "[body].semi_axes": ["[point].law", "[initial].com", "[body].center", "[body].shape"],
    "[body].center": ["[point].law", "[initial].com", "[body].radius"],
    "[initial].com": ["[body].radius", "[body].center", "[body].shape"],
    "[initial].time": ["[run].duration"],
    "[run].duration": ["[initial].time", "[run].step", "[run].max_steps", "[run].output_dt",
                       "[run].zeno_dt", "[point].law", "[point].samples", "[point].table"],
    "[run].step": ["[run].duration", "[run].max_steps"],
    "[run].output_dt": ["[run].duration"],
    "[run].zeno_dt": ["[run].duration"],
    "[run].rtol": ["[run].atol"], "[run].atol": ["[run].rtol"],
    "[run].max_steps": ["[run].duration", "[run].step", "[point].law", "[point].samples",
                        "[point].table"],
    "[initial].quaternion": ["[initial].matrix"],
}


def fname(path) -> str:
    if isinstance(path, str):
        return path
    if len(path) == 1:
        return path[0]
    return f"[{path[0]}]." + ".".join(path[1:])


def fields_for(path) -> tuple:
    f = fname(path)
    return (f, *RELATED.get(f, ()))


def _set(doc: dict, path, value) -> dict:
    d = doc
    for k in path[:-1]:
        d = d.setdefault(k, {})
    d[path[-1]] = value
    return doc


def _del(doc: dict, path) -> dict:
    d = doc
    for k in path[:-1]:
        d = d[k]
    d.pop(path[-1], None)
    return doc


def _deep_list(depth: int, leaf=1.0):
    v = leaf
    for _ in range(depth):
        v = [v]
    return v


def _deep_dict(depth: int):
    v = {"a": 1.0}
    for _ in range(depth):
        v = {"a": v}
    return v


NONFINITE = (math.nan, math.inf, -math.inf)
HUGE = (1e308, -1e308, 1.7976931348623157e308, 1e200)
BIGINT = (2 ** 63 - 1, 2 ** 63, 10 ** 30, -(2 ** 63), 2 ** 64 + 1, 10 ** 400)
TINY = (1e-300, 5e-324, 2.2250738585072014e-308, 1e-320)
WRONG_TYPES = ("1.0", "", True, False, [1.0], {"a": 1.0}, [], "nan", "0x10", "\uff11")


def scene_mutation(rng: random.Random, index: int, marker: str) -> Case:
    doc = base_scene()
    r = rng.random()
    if r < 0.35:          # a number
        path, rule = rng.choice(list(NUMBER_FIELDS.items()))
        kind = rng.choice(("nonfinite", "huge", "bigint", "tiny", "zero", "negative",
                           "wrongtype", "int", "deep", "mid"))
        expect = "either"
        if kind == "nonfinite":
            v = rng.choice(NONFINITE)
            expect = "refuse"
        elif kind == "huge":
            v = rng.choice(HUGE)
            expect = "refuse" if rule != "count" or v < 0 else "either"
        elif kind == "bigint":
            v = rng.choice(BIGINT)
            expect = "refuse" if rule != "count" or v < 0 or v >= 2 ** 63 else "either"
        elif kind == "tiny":
            v = rng.choice(TINY)
            expect = "refuse" if rule in ("count",) else "either"
        elif kind == "zero":
            v = rng.choice((0.0, -0.0, 0))
            expect = "refuse" if rule in ("pos",) else "either"
        elif kind == "negative":
            v = rng.choice((-1.0, -1e-12, -5))
            expect = "refuse" if rule in ("pos", "nonneg", "unit", "count") else "either"
            if path == ("run", "g"):
                expect = "either"
        elif kind == "wrongtype":
            v = rng.choice(WRONG_TYPES)
            expect = "refuse"
        elif kind == "int":
            v = rng.choice((1, 2, 3))
            expect = "either"
        elif kind == "deep":
            v = _deep_list(rng.choice((2, 50, 5000)))
            expect = "refuse"
        else:                 # 1e30, 1.5 for counts
            v = rng.choice((1e30, 1e15, 1.5, 1e-30))
            expect = "either"
            if rule == "unit" and v > 1:
                expect = "refuse"
        if path == ("run", "step"):
            doc["run"]["method"] = "rk4"
        _set(doc, path, v)
        return Case(index, "scene", f"{fname(path)} = {_short(v)}", doc, expect=expect,
                    fields=fields_for(path), toml_level_ok=kind == "deep")
    if r < 0.55:          # a vector
        path, rule = rng.choice(list(VECTOR_FIELDS.items()))
        base = list(doc[path[0]][path[1]])
        kind = rng.choice(("element", "length", "scalar", "wrongtype", "nested", "deep",
                           "zero"))
        expect = "refuse"
        if kind == "element":
            k = rng.randrange(len(base))
            v = rng.choice(NONFINITE + HUGE + BIGINT[:3] + ("1", True, None))
            if v is None:
                v = [1.0, 2.0]
            base[k] = v
            value = base
            if isinstance(v, int) and not isinstance(v, bool) and v < 2 ** 63 and \
                    rule == "quat":
                expect = "either"
        elif kind == "length":
            value = base[:rng.choice((0, 1, 2))] if rng.random() < 0.5 else base + [0.0] * \
                rng.choice((1, 2, 1000))
        elif kind == "scalar":
            value = 1.0
        elif kind == "wrongtype":
            value = rng.choice(("[1, 2, 3]", {"x": 1.0}, True))
        elif kind == "nested":
            value = [base]
        elif kind == "deep":
            value = _deep_list(rng.choice((3, 100, 5000)), 0.1)
        else:
            value = [0.0] * len(base)
            expect = "refuse" if rule in ("pos", "quat") else "either"
        _set(doc, path, value)
        return Case(index, "scene", f"{fname(path)} = {_short(value)}", doc, expect=expect,
                    fields=fields_for(path), toml_level_ok=kind == "deep")
    if r < 0.70:          # strings
        choices = [("name",), ("body", "shape"), ("run", "method"), ("run", "model"),
                   ("run", "outputs"), ("point", "law")]
        path = rng.choice(choices)
        s = rng.choice(hostile_strings(marker))
        if path == ("run", "outputs"):
            value = [s] if rng.random() < 0.5 else ["pose", s]
            expect = "refuse"
            f = fields_for(path)
        elif path == ("point", "law"):
            k = rng.randrange(3)
            value = list(doc["point"]["law"])
            value[k] = s
            expect = "refuse"
            f = (f"[point].law[{k}]",)
        elif path == ("name",):
            value = s
            expect = "either"
            f = ("name",)
        else:
            value = s
            expect = "refuse"
            f = fields_for(path)
        if rng.random() < 0.1 and path != ("point", "law"):
            value = rng.choice((1.0, True, ["sphere"], {"a": "b"}))
            expect = "refuse"
        _set(doc, path, value)
        return Case(index, "scene", f"{fname(path)} = {_short(value)}", doc, expect=expect,
                    fields=f)
    if r < 0.80:          # missing keys and tables
        paths = [(k,) for k in doc] + [(t, k) for t in doc if isinstance(doc[t], dict)
                                        for k in doc[t]]
        path = rng.choice(paths)
        _del(doc, path)
        return Case(index, "scene", f"without {fname(path)}", doc, expect="either",
                    fields=fields_for(path) + ((f"[{path[0]}]",) if len(path) == 1 else ()))
    if r < 0.90:          # extra keys
        where = rng.choice(("top", "body", "point", "plane", "initial", "run", "newtable",
                            "nested"))
        key = rng.choice(("colour", "rtoll", "Mass", "mass ", "law\x00", "__class__",
                          "shape.x", "k" * 1000, "\u043c\u0430ss"))
        if where == "top":
            doc[key] = 1.0
            f = (key,)
        elif where == "newtable":
            doc[key] = {"x": 1.0}
            f = (key,)
        elif where == "nested":
            doc["body"]["extra"] = _deep_dict(rng.choice((3, 200)))
            key, f = "extra", ("[body].extra", "extra")
            return Case(index, "scene", f"extra key {key!r:.40} in {where}", doc,
                        expect="refuse", fields=f, toml_level_ok=True)
        else:
            doc[where][key] = 1.0
            f = (f"[{where}].{_escaped(key)[:30]}", _escaped(key)[:30])
        if where in ("top", "newtable"):
            f = (_escaped(key)[:30],)
        return Case(index, "scene", f"extra key {key!r:.40} in {where}", doc,
                    expect="refuse", fields=f)
    # several things at once (either; must not crash)
    c1 = scene_mutation(rng, index, marker)
    c2 = scene_mutation(rng, index, marker)
    doc = c1.doc
    for t, v in c2.doc.items():
        if isinstance(v, dict) and isinstance(doc.get(t), dict):
            doc[t].update(v)
    return Case(index, "scene", f"{c1.desc} and {c2.desc}", doc, expect="either",
                fields=None)


def _escaped(key: str) -> str:
    """How a message shows a key: control characters escaped (\\x00)."""
    return CONTROL_RE.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), key)


def _short(v) -> str:
    depth = 0
    while isinstance(v, list) and len(v) == 1 and isinstance(v[0], list):
        v, depth = v[0], depth + 1
    if depth > 3:
        return f"a list nested {depth + 1} deep"
    s = repr(v)
    return s if len(s) < 80 else s[:70] + f"...({len(s)} chars)"


def law_case(rng: random.Random, index: int, marker: str) -> Case:
    doc = base_scene()
    k = rng.randrange(3)
    window = (0.0, doc["run"]["duration"])
    r = rng.random()
    laws = {}
    if r < 0.35:
        tree = random_law(rng, depth=rng.choice((1, 2, 3, 4)))
        text, expect, desc = law_text(tree), "either", "random"
        laws[k] = tree
        if rng.random() < 0.3:
            text = text.replace("**", "^")
    elif r < 0.60:
        kind, tree, a, inside = planted_law(rng, window)
        text = law_text(tree)
        expect = "refuse" if inside else "either"
        desc = f"{kind} at t = {a:.6g} ({'inside' if inside else 'outside'} the run)"
        laws[k] = tree
    elif r < 0.90:
        text = rng.choice(HOSTILE_LAWS + EITHER_LAWS).replace("MARKER", marker)
        expect, desc = ("either" if text in EITHER_LAWS else "refuse"), "hostile"
        if rng.random() < 0.3:    # inside a valid expression
            text = f"0.1*sin(t) + {text}"
    else:
        desc, text, expect = rng.choice(deep_laws())
    doc["point"]["law"][k] = text
    return Case(index, "law", f"law[{k}] {desc}: {text}", doc, expect=expect,
                fields=(f"[point].law[{k}]",), laws=laws, window=window)


def table_case(rng: random.Random, index: int, marker: str, outside: str) -> Case:
    """Tabulated laws: a file below the scene's folder, or samples inline."""
    doc = base_scene()
    good = csv_text(table_rows())
    r = rng.random()
    files: dict = {}
    expect, f = "refuse", ("[point].table",)
    point = {"mass": 0.2, "table": "law.csv"}
    if r < 0.45:
        kind = rng.choice((
            "dotdot", "absolute", "absolute-good", "symlink-out", "symlink-dev",
            "dev-zero", "dev-random", "fifo", "dir", "missing", "empty-name", "nul-name",
            "home", "proc", "inside-dotdot", "url", "glob", "backslash", "long-name"))
        if kind == "dotdot":
            point["table"] = "../" * rng.choice((1, 3, 8)) + "outside.csv"
            if point["table"] == "../outside.csv":
                files["../outside.csv"] = good.encode()
        elif kind == "absolute":
            point["table"] = rng.choice(("/etc/passwd", "/etc/hostname", "/"))
        elif kind == "absolute-good":
            point["table"] = outside
        elif kind == "symlink-out":
            files["law.csv"] = ("symlink", outside)
        elif kind == "symlink-dev":
            files["law.csv"] = ("symlink", "/dev/zero")
        elif kind == "dev-zero":
            point["table"] = "/dev/zero"
        elif kind == "dev-random":
            point["table"] = "/dev/urandom"
        elif kind == "fifo":
            files["law.csv"] = ("fifo",)
        elif kind == "dir":
            files["law.csv"] = ("dir",)
        elif kind == "missing":
            point["table"] = "nothere.csv"
        elif kind == "empty-name":
            point["table"] = rng.choice(("", ".", "./"))
        elif kind == "nul-name":
            point["table"] = "law.csv\x00.txt"
        elif kind == "home":
            point["table"] = "~/law.csv"
        elif kind == "proc":
            point["table"] = "/proc/self/environ"
        elif kind == "inside-dotdot":
            files["sub/x"] = b""
            files["law.csv"] = good.encode()
            point["table"] = "sub/../law.csv"
            expect = "either"
        elif kind == "url":
            point["table"] = "http://127.0.0.1:9/law.csv"
        elif kind == "glob":
            point["table"] = "*.csv"
        elif kind == "backslash":
            point["table"] = "..\\outside.csv"
        else:
            point["table"] = "a" * 5000 + ".csv"
        files.setdefault("law.csv", good.encode())
        desc = f"table path {kind}: {point['table']!r:.60}"
    elif r < 0.80:
        kind = rng.choice((
            "huge", "long-line", "ragged", "text", "nan", "inf", "big", "fullwidth",
            "unsorted", "duplicate", "one-row", "empty", "header-only", "binary", "bom",
            "crlf", "extra-col", "no-header", "short-range", "hostile-header", "quoted",
            "spaces", "jumps"))
        rows = table_rows()
        text = None
        expect = "refuse"
        if kind == "huge":
            n = 1_000_000
            t = np.linspace(0, 1, n)
            body = "\n".join(f"{float(a)!r},0.1,0.1,0.1" for a in t[:n])
            text = "t,x,y,z\n" + body + "\n"
            expect = "either"
        elif kind == "long-line":
            text = "t,x,y,z\n" + "1" * 5_000_000 + "\n"
        elif kind == "ragged":
            rows[rng.randrange(1, 100)] = rows[0][:rng.choice((1, 2, 3))]
        elif kind in ("text", "nan", "inf", "big", "fullwidth"):
            rr = rng.randrange(1, 100)
            cc = rng.randrange(4)
            rows[rr][cc] = {"text": "abc", "nan": "nan", "inf": "inf", "big": "1e400",
                            "fullwidth": "\uff10.1"}[kind]
        elif kind == "unsorted":
            rows[10], rows[20] = rows[20], rows[10]
        elif kind == "duplicate":
            rows[11] = list(rows[10])
        elif kind == "one-row":
            rows = rows[:rng.choice((0, 1, 2))]
            expect = "refuse"
        elif kind == "empty":
            text = ""
        elif kind == "header-only":
            text = "t,x,y,z\n"
        elif kind == "binary":
            text = bytes(rng.randrange(256) for _ in range(5000))
        elif kind == "bom":
            text = "\ufeff" + good
            expect = "either"
        elif kind == "crlf":
            text = good.replace("\n", "\r\n")
            expect = "either"
        elif kind == "extra-col":
            text = csv_text([r + [1.0] for r in rows], "t,x,y,z,w")
            expect = "either"
        elif kind == "no-header":
            text = good.split("\n", 1)[1]
        elif kind == "short-range":     # covers half the run
            rows = table_rows(51, 0.5)
            expect = "either"
        elif kind == "hostile-header":
            text = good.replace("t,x,y,z", f"t,x,y,z$(touch {marker})", 1)
        elif kind == "quoted":
            text = good.replace("0.1,", '"0.1",')
            expect = "either"
        elif kind == "spaces":
            text = good.replace(",", ", ")
            expect = "either"
        else:                          # a step in x: not C^2
            rows = [[r[0], r[1] + (0.05 if r[0] > 0.5 else 0.0), r[2], r[3]] for r in rows]
            expect = "either"
        if text is None:
            text = csv_text(rows)
        files["law.csv"] = text if isinstance(text, bytes) else text.encode("utf-8")
        desc = f"table file {kind}"
    else:
        f = ("[point].samples", "[point].ends")
        rows = table_rows()
        kind = rng.choice(("flat", "short-rows", "long-rows", "empty", "one", "strings",
                           "nan", "bools", "nested", "unsorted", "both", "ends-bad",
                           "ends-type", "big", "many", "deep", "ends-periodic",
                           "scalar"))
        expect = "refuse"
        samples: object = rows
        point = {"mass": 0.2, "samples": samples}
        if kind == "flat":
            point["samples"] = [v for r in rows for v in r]
        elif kind == "short-rows":
            point["samples"] = [r[:3] for r in rows]
        elif kind == "long-rows":
            point["samples"] = [r + [0.0] for r in rows]
        elif kind == "empty":
            point["samples"] = []
        elif kind == "one":
            point["samples"] = rows[:1]
        elif kind == "strings":
            rows[5][2] = "0.1"
        elif kind == "nan":
            rows[5][rng.randrange(4)] = rng.choice(NONFINITE)
        elif kind == "bools":
            rows[5][1] = True
        elif kind == "nested":
            rows[5][1] = [0.1]
        elif kind == "unsorted":
            rows[3], rows[4] = rows[4], rows[3]
        elif kind == "both":
            point["law"] = ["0", "0", "0"]
            f = ("[point].samples", "[point].law", "[point]")
        elif kind == "ends-bad":
            point["ends"] = rng.choice(hostile_strings(marker)[:8] + ["Periodic", "loop"])
            f = ("[point].ends",)
        elif kind == "ends-type":
            point["ends"] = rng.choice((1, True, ["rest"]))
            f = ("[point].ends",)
        elif kind == "big":
            rows[7][1] = 1e300
        elif kind == "many":
            point["samples"] = table_rows(100_000)
            expect = "either"
        elif kind == "deep":
            point["samples"] = _deep_list(3000, 0.0)
            doc["point"] = point
            return Case(index, "table", "samples deep", doc, expect=expect, fields=f,
                        toml_level_ok=True)
        elif kind == "ends-periodic":
            point["ends"] = "periodic"
        else:
            point["samples"] = 1.0
        desc = f"samples {kind}"
        doc["point"] = point
        return Case(index, "table", desc, doc, expect=expect, fields=f)
    doc["point"] = point
    return Case(index, "table", desc, doc, files=files, expect=expect, fields=f)


def toml_case(rng: random.Random, index: int) -> Case:
    good = to_toml(base_scene())
    kind = rng.choice(("deep-array", "deep-inline", "bad-utf8", "nul", "duplicate",
                       "huge-comment", "dotted-conflict", "bom", "unterminated",
                       "huge-int", "ml-string-law", "control-char"))
    fields = None
    expect = "refuse"
    if kind == "deep-array":
        text = good.replace("inertia = [0.1, 0.12, 0.14]",
                            "inertia = " + "[" * 5000 + "]" * 5000)
    elif kind == "deep-inline":
        text = good + "\n[extra]\nx = " + "{a = " * 3000 + "1" + "}" * 3000 + "\n"
    elif kind == "bad-utf8":
        text = good.encode() + b"\nname2 = \"\xff\xfe\"\n"
    elif kind == "nul":
        text = good.replace('name = "bouncing-ball"', 'name = "a\x00b"')
    elif kind == "duplicate":
        text = good + "\n[body]\nmass = 2.0\n"
    elif kind == "huge-comment":
        text = good + "#" + "x" * 20_000_000 + "\n"
        expect = "either"
    elif kind == "dotted-conflict":
        text = "body.mass = 1.0\n" + good
    elif kind == "bom":
        text = "\ufeff" + good
        expect = "either"
    elif kind == "unterminated":
        text = good[: len(good) // 2]
    elif kind == "huge-int":
        text = good.replace("mass = 1.0", "mass = " + "9" * 5000, 1)   # the reader's
        fields = None                                                  # limit: file named
    elif kind == "ml-string-law":
        text = good.replace('"0.1"', '"""0.1\n*t"""', 1)
        fields = ("[point].law[1]",)
    else:
        text = good.replace('name = "bouncing-ball"', 'name = "a\x07b"')
    return Case(index, "toml", f"TOML {kind}", None, text=text, expect=expect,
                fields=fields)


def generate(n: int, seed: int = 12, mode: str = "api") -> list[Case]:
    """n cases from the seed, in the proportions scene 45%, law 35%, table 15%, toml 5%."""
    rng = random.Random(seed)
    marker = "MARKER_PWNED"
    cases = []
    for i in range(n):
        r = rng.random()
        if r < 0.45:
            c = scene_mutation(rng, i, marker)
        elif r < 0.80:
            c = law_case(rng, i, marker)
        elif r < 0.95:
            c = table_case(rng, i, marker, outside="OUTSIDE")
        else:
            c = toml_case(rng, i)
        cases.append(c)
    return cases


# ---- TOML writer (tomllib reads only) ----------------------------------------------
_ESC = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f",
        "\r": "\\r"}


def _toml_str(s: str) -> str:
    out = []
    for ch in s:
        if ch in _ESC:
            out.append(_ESC[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        elif 0xD800 <= ord(ch) <= 0xDFFF:
            out.append("\\ufffd")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else _toml_str(k)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) \
            + "}"
    if v is None:
        return '""'
    raise TypeError(type(v))


def to_toml(doc: dict) -> str:
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 20000))
    lines = []
    for k, v in doc.items():
        if not isinstance(v, dict):
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    for k, v in doc.items():
        if isinstance(v, dict):
            lines.append(f"\n[{_toml_key(k)}]")
            for kk, vv in v.items():
                lines.append(f"{_toml_key(kk)} = {_toml_value(vv)}")
    return "\n".join(lines) + "\n"


# ---- the worker: parse (and run) in a forked process with time and memory limits ----
def _limit_memory():
    try:
        import resource
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    except (ImportError, ValueError, OSError):
        pass


def _serve(conn):
    _limit_memory()
    sys.setrecursionlimit(10_000)
    while True:
        try:
            job = conn.recv()
        except EOFError:
            return
        if job is None:
            return
        try:
            out = _evaluate(job)
        except BaseException as exc:      # the evaluation itself failed
            out = {"status": "error", "type": type(exc).__name__,
                   "tb": traceback.format_exc()[-3000:]}
        try:
            conn.send(out)
        except Exception as exc:
            conn.send({"status": "error", "type": "unpicklable", "tb": repr(exc)})


def _evaluate(job: dict) -> dict:
    import warnings
    from ..scene import SceneError, load_scene, parse_scene
    out: dict = {"status": "accepted", "warnings": []}
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            if job.get("path"):
                scene = load_scene(job["path"])
            else:
                src = job["doc"] if job.get("doc") is not None else job["text"]
                if isinstance(src, bytes):
                    src = src.decode("utf-8", errors="strict")
                scene = parse_scene(src, "fuzz", Path(job["base"]) if job.get("base")
                                    else None)
        except SceneError as exc:
            return {"status": "refused", "where": getattr(exc, "where", None),
                    "rule": getattr(exc, "rule", None), "message": str(exc),
                    "seconds": time.perf_counter() - start}
        except BaseException as exc:
            return {"status": "error", "type": type(exc).__name__,
                    "message": str(exc)[:300], "tb": traceback.format_exc()[-3000:],
                    "seconds": time.perf_counter() - start}
        out["seconds"] = time.perf_counter() - start
        out["warnings"] += [f"{w.category.__name__}: {w.message}" for w in caught]
    # the law against an independent evaluation
    problems = []
    if job.get("laws"):
        try:
            problems += _check_laws(scene, job["laws"], job["window"], job["size"])
        except Exception:
            problems.append("fuzzer-error: " + traceback.format_exc()[-600:])
    out["problems"] = problems
    if job.get("simulate"):
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                from ..runtime.driver import simulate
                result = simulate(scene)
            except SceneError as exc:
                return {"status": "refused", "where": getattr(exc, "where", None),
                        "rule": getattr(exc, "rule", None), "message": str(exc),
                        "late": True, "seconds": out["seconds"]}
            except BaseException as exc:
                return {"status": "error", "type": type(exc).__name__,
                        "message": str(exc)[:300], "tb": traceback.format_exc()[-3000:],
                        "seconds": time.perf_counter() - start, "stage": "simulate"}
            out["run_seconds"] = time.perf_counter() - start
            out["run_status"] = result.status
            try:
                problems += _check_run(result, job)
            except Exception:
                problems.append("fuzzer-error: " + traceback.format_exc()[-600:])
            out["warnings"] += [f"{w.category.__name__}: {w.message}" for w in caught]
    return out


def _check_laws(scene, laws: dict, window, size) -> list:
    """Values and derivatives of the accepted law against :func:`jets` of its tree."""
    t0, t1 = window
    t = np.concatenate([np.linspace(t0, t1, 20001),
                        np.random.default_rng(0).uniform(t0, t1, 200)])
    problems = []
    with np.errstate(all="ignore"):
        try:
            got = np.asarray(scene.law.jets(t))
        except Exception as exc:
            return [f"law.jets failed: {exc!r}"]
        for k, tree in laws.items():
            mine = jets(tree, t)
            for d in range(3):
                want = np.broadcast_to(mine[d], t.shape)
                if not np.isfinite(want).all():
                    i = int(np.argmin(np.isfinite(want)))
                    problems.append(f"silent-accept: law[{k}] derivative {d} is not finite "
                                    f"at t = {t[i]:.9g} ({want[i]})")
                    break
                if d == 0 and np.abs(want).max() > SIZE_LIMIT * size:
                    problems.append(f"silent-accept: |law[{k}]| reaches "
                                    f"{np.abs(want).max():.3g} (body size {size})")
                    break
                g = got[3 * k + d]
                scale = max(1.0, float(np.abs(want).max()))
                err = float(np.abs(g - want).max())
                if not err <= 1e-7 * scale:
                    i = int(np.nanargmax(np.abs(g - want))) if np.isfinite(err) else 0
                    problems.append(f"wrong-answer: law[{k}] derivative {d} differs from the "
                                    f"expression by {err:.3g} at t = {t[i]:.9g} "
                                    f"(runtime {g[i]:.9g}, expression {want[i]:.9g})")
                    break
    return problems


def _check_run(result, job) -> list:
    """What any honest run satisfies: finite rows, an end time that matches the status,
    X_C and Y_C uniform (the plane is smooth), A a rotation, S not below the plane."""
    problems = []
    scene = result.scene
    t = np.asarray(result.t)
    q = np.asarray(result.model_q)
    if len(t) == 0:
        return ["wrong-answer: no rows"]
    if not (np.isfinite(t).all() and np.isfinite(q).all()):
        problems.append(f"wrong-answer: non-finite rows (status {result.status})")
        return problems
    if result.status == "nonfinite":
        problems.append("silent-accept: an accepted scene ends nonfinite")
    t_end = scene.t0 + scene.duration
    if result.status == "done" and abs(t[-1] - t_end) > 1e-9 * max(1.0, abs(t_end)):
        problems.append(f"wrong-answer: says done but ends at t = {t[-1]!r}")
    if np.any(np.diff(t) < 0):
        problems.append("wrong-answer: rows not in time order")
    ev = result.event_rows
    if result.status == "max_events" and len(ev) < min(scene.max_events, 1e9):
        problems.append(f"wrong-answer: max_events after {len(ev)} events "
                        f"(max_events = {scene.max_events!r})")
    if result.status == "max_steps" and result.stats.get("steps", 0) < \
            min(scene.max_steps, 1e12) - 1:
        problems.append(f"wrong-answer: max_steps after {result.stats.get('steps')} steps "
                        f"(max_steps = {scene.max_steps!r})")
    g = result.general
    if g is not None and len(g):
        g = np.asarray(g)
        x0, v0 = np.asarray(scene.com, float), np.asarray(scene.com_velocity, float)
        for i in (0, 1):
            want = x0[i] + v0[i] * (t - scene.t0)
            err = np.abs(g[:, i] - want)
            tol = 1e-6 * (1 + np.abs(want))
            if (err > tol).any():
                k = int(np.argmax(err - tol))
                problems.append(f"wrong-answer: {'XY'[i]}_C = {g[k, i]:.6g} at t = "
                                f"{t[k]:.6g}, the uniform motion gives {want[k]:.6g}")
                break
        A = g[:, 9:18].reshape(-1, 3, 3)
        err = np.abs(np.einsum("nij,nkj->nik", A, A) - np.eye(3)).max(axis=(1, 2))
        tight = scene.method != "rk4" and scene.rtol <= 1e-6 and scene.atol <= 1e-6
        if tight and (err > 1e-4).any() or (err > 0.1).any():
            k = int(np.argmax(err))
            problems.append(f"wrong-answer: A A^T - 1 = {err[k]:.3g} at t = {t[k]:.6g} "
                            f"(a_ij = {A[k].ravel().min():.3g} .. {A[k].ravel().max():.3g})")
        if not scene.contact_possible and result.status == "done":
            z = scene.com[2] + scene.com_velocity[2] * (t - scene.t0) - \
                0.5 * scene.g * (t - scene.t0) ** 2
            err = np.abs(g[:, 2] - z)
            if (err > 1e-6 * (1 + np.abs(z))).any():
                k = int(np.argmax(err))
                problems.append(f"wrong-answer: free flight Z_C = {g[k, 2]:.6g} at t = "
                                f"{t[k]:.6g}, the parabola gives {z[k]:.6g}")
    if scene.contact_possible and result.height is not None:
        h = np.asarray(result.height)
        size = job.get("size") or 1.0
        if h.size and h.min() < -1e-6 * size:
            k = int(np.argmin(h))
            problems.append(f"wrong-answer: S at {h[k]:.3g} below the plane at t = {t[k]:.6g}")
    return problems


class Worker:
    """A forked process that evaluates jobs one at a time; killed and restarted on a
    hang or a crash."""

    def __init__(self):
        self.ctx = multiprocessing.get_context("fork")
        self.proc = None
        self._start()

    def _start(self):
        self.conn, child = self.ctx.Pipe()
        self.proc = self.ctx.Process(target=_serve, args=(child,), daemon=True)
        self.proc.start()
        child.close()

    def _restart(self):
        if self.proc.is_alive():
            os.kill(self.proc.pid, signal.SIGKILL)
        self.proc.join(5)
        self.conn.close()
        self._start()

    def call(self, job: dict, timeout: float) -> dict:
        start = time.perf_counter()
        self.conn.send(job)
        if not self.conn.poll(timeout):
            self._restart()
            return {"status": "timeout", "seconds": time.perf_counter() - start}
        try:
            return self.conn.recv()
        except (EOFError, OSError):
            code = self.proc.exitcode
            self._restart()
            return {"status": "crash", "exitcode": code,
                    "seconds": time.perf_counter() - start}

    def close(self):
        try:
            self.conn.send(None)
        except (OSError, BrokenPipeError):
            pass
        self.proc.join(2)
        if self.proc.is_alive():
            os.kill(self.proc.pid, signal.SIGKILL)
            self.proc.join(2)


def _materialise(case: Case, folder: Path, outside: Path) -> Path | None:
    """Write the case's files (and the scene file when it has files) below folder."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, content in case.files.items():
        p = folder / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, tuple):
            if content[0] == "symlink":
                target = str(outside) if content[1] == "OUTSIDE" else content[1]
                os.symlink(target, p)
            elif content[0] == "fifo":
                os.mkfifo(p)
            elif content[0] == "dir":
                p.mkdir()
        else:
            p.write_bytes(content)
    return folder


def _names_field(message: str) -> bool:
    return bool(FIELD_RE.match(message.strip()))


def judge_api(case: Case, res: dict, run_limit: float) -> Outcome:
    st = res.get("status")
    secs = res.get("seconds", 0.0) + res.get("run_seconds", 0.0)
    if st == "timeout":
        return Outcome(case, "hang", "no answer within the time limit", secs)
    if st == "crash":
        return Outcome(case, "crash", f"worker died (exit code {res.get('exitcode')})", secs)
    if st == "error":
        where = " while simulating" if res.get("stage") else ""
        last = [ln for ln in res.get("tb", "").strip().splitlines() if ln.strip()]
        return Outcome(case, "traceback", f"{res.get('type')}{where}: "
                       f"{(last[-1] if last else '')[:160]}", secs)
    if st == "refused":
        msg = res.get("message", "")
        if "\n" in msg.strip():
            return Outcome(case, "multi-line", msg[:200], secs, msg)
        if CONTROL_RE.search(msg):
            return Outcome(case, "control-chars", f"raw control characters: {msg[:160]!r}",
                           secs, msg)
        if res.get("seconds", 0.0) > PARSE_LIMIT_S:
            return Outcome(case, "hang", f"refused after {res['seconds']:.1f} s", secs, msg)
        if case.fields is not None and not _names_field(msg):
            return Outcome(case, "wrong-field", f"names no field: {msg[:160]}", secs, msg)
        if case.fields and not any(f in msg for f in case.fields):
            return Outcome(case, "wrong-field", f"wants {case.fields[0]}: {msg[:160]}",
                           secs, msg)
        return Outcome(case, "refused", "", secs, msg)
    # accepted
    problems = list(res.get("problems", []))
    if res.get("seconds", 0.0) > PARSE_LIMIT_S:
        return Outcome(case, "hang", f"accepted after {res['seconds']:.1f} s", secs)
    if case.expect == "refuse":
        return Outcome(case, "silent-accept", f"accepted (run: {res.get('run_status')}) "
                       + "; ".join(problems)[:200], secs)
    for p in problems:
        verdict = p.split(":", 1)[0]
        return Outcome(case, verdict if verdict in BAD else "wrong-answer", p[:300], secs)
    if res.get("warnings"):
        return Outcome(case, "warning", "; ".join(res["warnings"])[:200], secs)
    if res.get("run_seconds", 0.0) > run_limit:
        return Outcome(case, "hang", f"ran for {res['run_seconds']:.1f} s", secs)
    status = res.get("run_status", "done")
    return Outcome(case, "ran-ok" if status == "done" else "ran-status",
                   "" if status == "done" else status, secs)


def run_api(cases: list[Case], simulate: bool = True, parse_limit: float = PARSE_LIMIT_S,
            run_limit: float = RUN_LIMIT_S, progress=None) -> list[Outcome]:
    """Each case through ``parse_scene`` (and ``simulate`` when accepted) in a worker."""
    from .. import scene  # noqa: F401  (imported once, before the fork)
    from ..runtime import driver  # noqa: F401
    warm = base_scene()                     # table laws import their own modules
    warm["point"] = {"mass": 0.2, "samples": table_rows()}
    try:
        scene.parse_scene(warm, "warm-up")
    except Exception:
        pass
    if simulate:
        from ..runtime.build import library
        library("general")
    out = []
    tmp = Path(tempfile.mkdtemp(prefix="derive-fuzz-"))
    outside = tmp / "outside.csv"
    outside.write_text(csv_text(table_rows()))
    worker = Worker()
    try:
        for case in cases:
            folder = tmp / f"c{case.index}" / "scene"
            job = {"simulate": simulate, "laws": case.laws, "window": case.window,
                   "size": case.size}
            if case.doc is not None:
                doc = copy.deepcopy(case.doc)
                _fix_outside_doc(doc, outside)
                if case.files or _has_table(doc):
                    _materialise(case, folder, outside)
                    (folder / "scene.toml").write_text(to_toml(doc), encoding="utf-8")
                    job["path"] = str(folder / "scene.toml")
                else:
                    job["doc"] = doc
            else:
                folder.mkdir(parents=True, exist_ok=True)
                text = case.text if isinstance(case.text, bytes) else \
                    case.text.encode("utf-8", errors="surrogatepass")
                (folder / "scene.toml").write_bytes(text)
                job["path"] = str(folder / "scene.toml")
            limit = parse_limit + (run_limit if simulate else 0.0) + 1.0
            res = worker.call(job, limit)
            if res.get("status") == "timeout" and simulate:
                # a hang in validation or in the run? ask once more without the run
                res2 = worker.call({**job, "simulate": False}, parse_limit + 1.0)
                if res2.get("status") != "timeout":
                    res = {**res2, "run_seconds": limit, "run_status": "timeout"}
                    o = judge_api(case, res, run_limit)
                    if not o.bad:
                        o = Outcome(case, "hang", f"run past {limit:.0f} s", limit)
                    out.append(o)
                    continue
            out.append(judge_api(case, res, run_limit))
            shutil.rmtree(tmp / f"c{case.index}", ignore_errors=True)
            if progress and len(out) % 100 == 0:
                progress(f"{len(out)}/{len(cases)}")
    finally:
        worker.close()
        shutil.rmtree(tmp, ignore_errors=True)
    return out


def _has_table(doc) -> bool:
    pt = doc.get("point") if isinstance(doc, dict) else None
    return isinstance(pt, dict) and "table" in pt


def _fix_outside_doc(doc, outside: Path) -> None:
    pt = doc.get("point") if isinstance(doc, dict) else None
    if isinstance(pt, dict) and pt.get("table") == "OUTSIDE":
        pt["table"] = str(outside)


# ---- the command line -------------------------------------------------------------
def _snapshot(root: Path) -> set:
    found = set()
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for n in dirnames + filenames:
            found.add(os.path.join(dirpath, n))
    return found


def cli_env(home: Path, cache: Path) -> dict:
    env = {k: v for k, v in os.environ.items()
           if k in ("PATH", "LANG", "LC_ALL", "VIRTUAL_ENV", "SYSTEMROOT", "TMPDIR")}
    env.update(HOME=str(home), DERIVE_CACHE=str(cache), PYTHONDONTWRITEBYTECODE="1",
               MPLCONFIGDIR=str(home / ".mpl"), PYTHONPATH=str(Path(__file__).parents[2]))
    return env


def run_cli_one(case: Case, cache: Path, limit: float = CLI_LIMIT_S,
                keep: bool = False) -> Outcome:
    """``derive simulate scene.toml -o out`` in a private folder: HOME and cwd are
    root = <tmp>/a/b/c/home (so that ../../ escapes stay inside <tmp> and are seen)."""
    tmp = Path(tempfile.mkdtemp(prefix="derive-fuzz-cli-"))
    try:
        root = tmp / "a" / "b" / "c" / "home"
        root.mkdir(parents=True)
        (root / ".mpl").mkdir()
        outside = tmp / "outside.csv"
        outside.write_text(csv_text(table_rows()))
        if case.doc is not None:
            doc = copy.deepcopy(case.doc)
            _fix_outside_doc(doc, outside)
            text = to_toml(doc).encode("utf-8")
        else:
            text = case.text if isinstance(case.text, bytes) else case.text.encode("utf-8")
        _materialise(case, root, outside)
        (root / "scene.toml").write_bytes(text)
        before = _snapshot(tmp)
        start = time.perf_counter()
        cmd = [sys.executable, "-m", "derive", "simulate", "-q", "--no-plots", "scene.toml",
               "-o", "out"]
        proc = subprocess.Popen(cmd, cwd=root, env=cli_env(root, cache),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                stdin=subprocess.DEVNULL, start_new_session=True,
                                preexec_fn=_limit_memory)
        try:
            so, se = proc.communicate(timeout=limit)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            return Outcome(case, "hang", f"no exit within {limit:.0f} s", limit)
        secs = time.perf_counter() - start
        err = se.decode("utf-8", errors="replace")
        after = _snapshot(tmp)
        new = sorted(after - before)
        out_dir = root / "out"
        outside_new = [p for p in new if not p.startswith(str(out_dir) + os.sep)
                       and p != str(out_dir)]
        lines = err.strip().splitlines()
        rc = proc.returncode
        if "Traceback" in err:
            last = lines[-1] if lines else ""
            return Outcome(case, "traceback", f"exit {rc}: {last[:160]}", secs, err[-2000:])
        if outside_new:
            return Outcome(case, "outside-files", f"exit {rc}, created {outside_new[:3]}",
                           secs, err)
        if rc == 2:
            msg = lines[0] if lines else ""
            if len(lines) != 1:
                return Outcome(case, "multi-line", f"{len(lines)} lines on stderr: "
                               f"{err[:160]!r}", secs, err)
            if out_dir.exists():
                return Outcome(case, "wrote-files", f"out/ exists after a refusal: {msg}",
                               secs, msg)
            if not msg.startswith("derive simulate: "):
                return Outcome(case, "wrong-field", f"not 'derive simulate:': {msg[:160]}",
                               secs, msg)
            body = msg[len("derive simulate: "):]
            if CONTROL_RE.search(body):
                return Outcome(case, "control-chars", f"raw control characters: "
                               f"{msg[:160]!r}", secs, msg)
            if case.fields is not None and not _names_field(body):
                return Outcome(case, "wrong-field", f"names no field: {msg[:160]}", secs,
                               msg)
            if case.toml_level_ok and body.startswith("scene.toml: is nested too deeply"):
                return Outcome(case, "refused", "", secs, msg)
            if case.fields and not any(f in body for f in case.fields):
                return Outcome(case, "wrong-field", f"wants {case.fields[0]}: {msg[:160]}",
                               secs, msg)
            return Outcome(case, "refused", "", secs, msg)
        if rc in (0, 1):
            if case.expect == "refuse":
                return Outcome(case, "silent-accept", f"exit {rc}: "
                               f"{so.decode(errors='replace').splitlines()[:1]}", secs, err)
            if "Warning" in err:
                return Outcome(case, "warning", err.strip()[:200], secs, err)
            if not out_dir.exists():
                return Outcome(case, "wrong-exit", f"exit {rc} but no out/", secs, err)
            if secs > limit / 2:
                return Outcome(case, "hang", f"took {secs:.1f} s", secs, err)
            return Outcome(case, "ran-ok" if rc == 0 else "ran-status",
                           so.decode(errors="replace").splitlines()[0][:120] if so else "",
                           secs, err)
        return Outcome(case, "wrong-exit", f"exit {rc}: {err.strip()[-160:]!r}", secs, err)
    finally:
        if not keep:
            shutil.rmtree(tmp, ignore_errors=True)


def run_cli(cases: list[Case], cache: Path | None = None, limit: float = CLI_LIMIT_S,
            workers: int = 2, progress=None) -> list[Outcome]:
    from concurrent.futures import ThreadPoolExecutor
    own = cache is None
    cache = cache or Path(tempfile.mkdtemp(prefix="derive-fuzz-cache-"))
    try:
        with ThreadPoolExecutor(workers) as pool:
            out = []
            for o in pool.map(lambda c: run_cli_one(c, cache, limit), cases):
                out.append(o)
                if progress and len(out) % 20 == 0:
                    progress(f"{len(out)}/{len(cases)}")
        return out
    finally:
        if own:
            shutil.rmtree(cache, ignore_errors=True)


def run(n: int = 2000, seed: int = 12, mode: str = "api", simulate: bool = True,
        progress=None, cli_cases: int | None = None) -> list[Outcome]:
    """n seeded cases through the API (``mode="api"``), the command line (``"cli"``) or
    both (``"both"``: all through the API, the first ``cli_cases`` also through the CLI)."""
    cases = generate(n, seed)
    out = []
    if mode in ("api", "both"):
        out += run_api(cases, simulate=simulate, progress=progress)
    if mode in ("cli", "both"):
        sub = cases if mode == "cli" else cases[: (cli_cases or max(1, n // 10))]
        out += run_cli(sub, progress=progress)
    return out


def report(outcomes: list[Outcome], limit: int = 60) -> str:
    from collections import Counter
    counts = Counter(o.verdict for o in outcomes)
    secs = np.array([o.seconds for o in outcomes]) if outcomes else np.zeros(1)
    lines = [f"{len(outcomes)} hostile cases: " +
             ", ".join(f"{k} {counts[k]}" for k in GOOD + BAD if counts.get(k)),
             f"time per case: median {1e3 * np.median(secs):.1f} ms, max {secs.max():.2f} s"]
    fams = Counter((o.case.family, o.verdict) for o in outcomes)
    for fam in ("scene", "law", "table", "toml", "explicit"):
        row = {v: c for (f, v), c in fams.items() if f == fam}
        if row:
            lines.append(f"  {fam:6s} " + ", ".join(f"{k} {v}" for k, v in sorted(row.items())))
    bad = [o for o in outcomes if o.bad]
    seen = set()
    for o in bad:
        key = (o.verdict, o.case.family, o.detail[:50])
        if key in seen:
            continue
        seen.add(key)
        if len(seen) > limit:
            break
        lines.append(f"  BAD {o.verdict} #{o.case.index} [{o.case.short()}]: {o.detail}")
    groups: dict = {}
    for o in bad:
        groups.setdefault(o.verdict, []).append(f"#{o.case.index} {o.case.short()[:50]}")
    for v, items in groups.items():
        lines.append(f"  {v} ({len(items)}): " + "; ".join(items[:40]))
    lines.append(f"goal: no BAD outcome ({'PASS' if not bad else f'FAIL: {len(bad)}'})")
    return "\n".join(lines)


def main(argv=None) -> int:
    import argparse
    p = argparse.ArgumentParser(prog="python -m derive.bench.fuzz")
    p.add_argument("-n", type=int, default=2000)
    p.add_argument("--seed", type=int, default=12)
    p.add_argument("--mode", choices=("api", "cli", "both"), default="api")
    p.add_argument("--cli-cases", type=int)
    p.add_argument("--no-simulate", action="store_true")
    a = p.parse_args(argv)
    start = time.perf_counter()
    out = run(a.n, a.seed, a.mode, simulate=not a.no_simulate, cli_cases=a.cli_cases,
              progress=lambda m: print("  ...", m, file=sys.stderr, flush=True))
    print(report(out))
    print(f"{time.perf_counter() - start:.1f} s")
    return 1 if any(o.bad for o in out) else 0


if __name__ == "__main__":
    raise SystemExit(main())

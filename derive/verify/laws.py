"""Point laws for the fuzzer: trees of the README's grammar, their text, and hostile text.

A law tree is a nested tuple: ``("num", value, text)``, ``("t",)``, ``("pi",)``,
``("neg", a)``, ``("fn", name, a)`` and ``(op, a, b)`` for op in add, sub, mul, div,
pow (``**``) and hat (``^``).  :func:`law_text` prints a tree in the grammar of
``[point].law``; :func:`derive.verify.oracle.jets` evaluates the same tree (value and two
derivatives) independently of the runtime's parser.  Random trees
(:func:`random_law`) are smooth where they are defined; :func:`planted_law` plants a pole,
a branch point or a kink at a chosen time; ``HOSTILE_LAWS``, ``EITHER_LAWS`` and
:func:`deep_laws` are texts a parser must refuse (or may accept) in one line.
"""
from __future__ import annotations

import math
import random


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


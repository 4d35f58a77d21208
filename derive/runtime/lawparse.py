"""Point laws such as ``"0.2*sin(3*t)"`` parsed by a whitelist, never by ``eval`` or
``sympify`` of the raw string.

Grammar (precedence climbing; ``**`` and ``^`` are right-associative and bind tighter
than unary minus, as in Python)::

    expr   := term (("+" | "-") term)*
    term   := unary (("*" | "/") unary)*
    unary  := ("+" | "-") unary | power
    power  := atom (("**" | "^") unary)?
    atom   := NUMBER | "t" | "pi" | NAME "(" expr ")" | "(" expr ")"

Names: the elementary functions of :data:`FUNCTIONS`.  The tree is built with SymPy
constructors directly; a string can only ever become numbers, ``t``, ``pi``, the
arithmetic operators and those functions.
"""
from __future__ import annotations

import math
import re

import sympy as sp

from .. import notation as nt

FUNCTIONS = {
    "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "exp": sp.exp, "log": sp.log,
    "sqrt": sp.sqrt, "sinh": sp.sinh, "cosh": sp.cosh, "tanh": sp.tanh,
    "asin": sp.asin, "acos": sp.acos, "atan": sp.atan,
}
MAX_LENGTH = 2000
MAX_DEPTH = 60

_TOKEN = re.compile(r"""
    (?P<ws>\s+)
  | (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z_0-9]*)
  | (?P<op>\*\*|[-+*/^()])
""", re.VERBOSE)


class LawError(ValueError):
    """A law expression that is malformed or uses something not on the whitelist."""


def _tokens(text: str) -> list[tuple[str, str, int]]:
    out, pos = [], 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m:
            raise LawError(f"unexpected character {text[pos]!r} at position {pos + 1}")
        kind = m.lastgroup
        if kind != "ws":
            out.append((kind, m.group(), pos + 1))
        pos = m.end()
    return out


class _Parser:
    def __init__(self, text: str):
        self.tokens = _tokens(text)
        self.i = 0
        self.depth = 0

    def peek(self):
        return self.tokens[self.i] if self.i < len(self.tokens) else ("end", "", -1)

    def take(self, value=None):
        tok = self.peek()
        if value is not None and tok[1] != value:
            where = f"position {tok[2]}" if tok[2] > 0 else "the end"
            raise LawError(f"expected {value!r} at {where}")
        self.i += 1
        return tok

    def deeper(self):
        self.depth += 1
        if self.depth > MAX_DEPTH:
            raise LawError(f"nested deeper than {MAX_DEPTH} levels")

    def expr(self):
        self.deeper()
        left = self.term()
        while self.peek()[1] in ("+", "-"):
            op = self.take()[1]
            right = self.term()
            left = sp.Add(left, right) if op == "+" else sp.Add(left, sp.Mul(-1, right))
        self.depth -= 1
        return left

    def term(self):
        left = self.unary()
        while self.peek()[1] in ("*", "/"):
            op = self.take()[1]
            right = self.unary()
            left = sp.Mul(left, right) if op == "*" else sp.Mul(left, sp.Pow(right, -1))
        return left

    def unary(self):
        if self.peek()[1] in ("+", "-"):
            op = self.take()[1]
            self.deeper()
            value = self.unary()
            self.depth -= 1
            return value if op == "+" else sp.Mul(-1, value)
        return self.power()

    def power(self):
        base = self.atom()
        if self.peek()[1] in ("**", "^"):
            self.take()
            self.deeper()
            exponent = self.unary()
            self.depth -= 1
            return sp.Pow(base, exponent)
        return base

    def atom(self):
        kind, value, pos = self.peek()
        if kind == "number":
            self.take()
            number = float(value)
            if not math.isfinite(number):
                raise LawError(f"number {value!r} at position {pos} is not finite")
            if re.fullmatch(r"\d+", value):
                return sp.Integer(int(value))
            return sp.Float(value, 17)
        if kind == "name":
            self.take()
            if value == "t":
                return nt.t
            if value == "pi":
                return sp.pi
            if value in FUNCTIONS:
                self.take("(")
                arg = self.expr()
                self.take(")")
                return FUNCTIONS[value](arg)
            allowed = ", ".join(["t", "pi", *FUNCTIONS])
            raise LawError(f"unknown name {value!r} at position {pos} (allowed: {allowed})")
        if value == "(":
            self.take()
            inner = self.expr()
            self.take(")")
            return inner
        where = f"position {pos}" if pos > 0 else "the end"
        raise LawError(f"expected a number, t, a function or '(' at {where}")


def parse_law(text: str) -> sp.Expr:
    """Parse one coordinate of a point law into a SymPy expression in ``t``."""
    if not isinstance(text, str):
        raise LawError("must be a string")
    if len(text) > MAX_LENGTH:
        raise LawError(f"longer than {MAX_LENGTH} characters")
    if not text.strip():
        raise LawError("is empty")
    parser = _Parser(text)
    value = parser.expr()
    if parser.i != len(parser.tokens):
        kind, tok, pos = parser.peek()
        raise LawError(f"unexpected {tok!r} at position {pos}")
    return value

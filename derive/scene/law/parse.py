"""Laws given as formulas, parsed by a whitelist into a :class:`~.program.Program`: no
string of a scene reaches generated source, ``eval`` or SymPy.  The builder folds
constants, recognises harmonics ``A sin(w t + p)`` (one node of the interpreter) and
shares every repeated subexpression (hash-consing), across all the strings it is given.
Each string is parsed once (:func:`_tape`: the builder's calls it makes, kept by the
text) and its calls replayed into each builder that needs it (a point's law, then the
program of every body; the variants of a study that share it).

Grammar (precedence climbing; ``**`` and ``^`` are right-associative and bind tighter
than unary minus, as in Python)::

    expr   := term (("+" | "-") term)*
    term   := unary (("*" | "/") unary)*
    unary  := ("+" | "-") unary | power
    power  := atom (("**" | "^") unary)?
    atom   := NUMBER | "t" | "pi" | NAME "(" expr ")" | "(" expr ")"

Limits: ASCII only, spaces and tabs as the only white space, at most
:data:`MAX_LENGTH` characters, nesting at most :data:`MAX_DEPTH`, at most
:data:`MAX_NODES` distinct operations per law, integer exponents at most
:data:`MAX_POWER` in size.  Constant subexpressions are evaluated in floats when parsed
and must be finite and real.
"""
from __future__ import annotations

import math
import re
from functools import lru_cache

from ..errors import LawError
from .ops import FUNCTIONS, MATH, OPS
from .program import Program

MAX_LENGTH = 2000
MAX_DEPTH = 60
MAX_NODES = 300
MAX_POWER = 64

_TOKEN = re.compile(r"""
    (?P<ws>[ \t]+)
  | (?P<number>(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)
  | (?P<name>[A-Za-z_][A-Za-z_0-9]*)
  | (?P<op>\*\*|[-+*/^()])
""", re.VERBOSE | re.ASCII)



# ---- building: hash-consing, constant folding --------------------------------------------
class _Builder:
    def __init__(self, limit: int = MAX_NODES):
        self.limit = limit             # distinct operations at most
        self.nodes: list = []          # (op, a, b)
        self.value: list = []          # float for constant nodes, else None
        self.consts: list = []
        self.index: dict = {}
        self.const_index: dict = {}
        self.affine: dict = {}         # node -> (w, p): the node is w t + p
        self.harmonic: dict = {}       # node -> (op, A, w, p): A sin|cos(w t + p)

    def _node(self, op, a, b, value=None) -> int:
        key = (op, a, b)
        k = self.index.get(key)
        if k is None:
            k = len(self.nodes)
            if k >= self.limit:
                raise LawError(f"has more than {self.limit} distinct operations")
            self.nodes.append(key)
            self.value.append(value)
            self.index[key] = k
        return k

    def _cidx(self, v: float) -> int:
        key = float(v).hex()
        if key not in self.const_index:
            self.const_index[key] = len(self.consts)
            self.consts.append(float(v))
        return self.const_index[key]

    def const(self, v: float, what: str = "a constant subexpression") -> int:
        if isinstance(v, complex) or not math.isfinite(v):
            raise LawError(f"{what} is not a finite real number")
        v = float(v) + 0.0                    # -0.0 -> 0.0
        return self._node("const", self._cidx(v), 0, v)

    def t(self) -> int:
        k = self._node("t", 0, 0)
        self.affine[k] = (1.0, 0.0)
        return k

    def _harmonic(self, op: str, A: float, w: float, p: float) -> int:
        """A harmonic as one node (the interpreter's superinstruction): A sin(w t + p) and
        its two derivatives from one sine and cosine, instead of four nodes."""
        if A == 0.0:
            return self.const(0.0)
        k = self._node(op, float(A).hex(), (float(w).hex(), float(p).hex()))
        self.harmonic[k] = (op, float(A), float(w), float(p))
        return k

    def _fused(self, op: str, a: int, b: int) -> int | None:
        """Harmonics and affine arguments recognised while building: c*(w t + p),
        (w t + p) + c, c*A sin(...), -A sin(...)."""
        va, vb = self.value[a], self.value[b]
        if op == "mul":
            c, x = (va, b) if va is not None else (vb, a) if vb is not None else (None, None)
            if c is None:
                return None
            if x in self.harmonic:
                h, A, w, p = self.harmonic[x]
                return self._harmonic(h, c * A, w, p)
            if x in self.affine:
                w, p = self.affine[x]
                k = self._node("mul", *sorted((a, b)))
                self.affine[k] = (c * w, c * p)
                return k
        elif op == "div" and vb is not None and a in self.affine:
            w, p = self.affine[a]
            k = self._node("div", a, b)
            self.affine[k] = (w / vb, p / vb)
            return k
        elif op in ("add", "sub"):
            if a in self.affine and vb is not None:
                w, p = self.affine[a]
                k = self._node(op, a, b)
                self.affine[k] = (w, p + vb if op == "add" else p - vb)
                return k
            if b in self.affine and va is not None:
                w, p = self.affine[b]
                k = self._node(op, *((a, b) if op == "sub" else sorted((a, b))))
                self.affine[k] = (w, va + p) if op == "add" else (-w, va - p)
                return k
        return None

    def is_const(self, k: int, v: float | None = None) -> bool:
        x = self.value[k]
        return x is not None and (v is None or x == v)

    def binary(self, op: str, a: int, b: int, text) -> int:
        va, vb = self.value[a], self.value[b]
        if va is not None and vb is not None:
            try:
                r = {"add": va + vb, "sub": va - vb, "mul": va * vb}[op] if op != "div" \
                    else va / vb
            except ZeroDivisionError:
                raise LawError(f"divides by zero in {text()}") from None
            return self.const(r, f"{text()}")
        if op == "add":
            if self.is_const(a, 0.0):
                return b
            if self.is_const(b, 0.0):
                return a
        elif op == "sub":
            if a == b:
                return self.const(0.0)
            if self.is_const(b, 0.0):
                return a
            if self.is_const(a, 0.0):
                return self._node("neg", b, 0)
        elif op == "mul":
            if self.is_const(a, 1.0):
                return b
            if self.is_const(b, 1.0):
                return a
            if self.is_const(a, -1.0):
                return self.neg(b)
            if self.is_const(b, -1.0):
                return self.neg(a)
        elif op == "div":
            if self.is_const(b, 0.0):
                raise LawError(f"divides by zero in {text()}")
            if self.is_const(b, 1.0):
                return a
        fused = self._fused(op, a, b)
        if fused is not None:
            return fused
        if op in ("add", "mul") and b < a:
            a, b = b, a                       # commutative: one canonical order
        return self._node(op, a, b)

    def neg(self, a: int) -> int:
        if self.value[a] is not None:
            return self.const(-self.value[a])
        op, x, _ = self.nodes[a]
        if op == "neg":
            return x
        if a in self.harmonic:
            h, A, w, p = self.harmonic[a]
            return self._harmonic(h, -A, w, p)
        return self._node("neg", a, 0)

    def call(self, name: str, a: int, text) -> int:
        va = self.value[a]
        if va is not None:
            try:
                r = MATH[name](va)
            except (ValueError, OverflowError):
                raise LawError(f"{text()} is not a finite real number") from None
            return self.const(r, text())
        if name in ("sin", "cos") and a in self.affine:
            w, p = self.affine[a]
            return self._harmonic("hsin" if name == "sin" else "hcos", 1.0, w, p)
        return self._node(name, a, 0)

    def power(self, a: int, b: int, text) -> int:
        va, vb = self.value[a], self.value[b]
        if vb is not None and abs(vb) > MAX_POWER:
            raise LawError(f"exponent {vb:g} in {text()} is larger than {MAX_POWER} in size")
        if va is not None and vb is not None:
            try:
                r = math.pow(va, vb)
            except (ValueError, OverflowError, ZeroDivisionError):
                raise LawError(f"{text()} is not a finite real number") from None
            return self.const(r, text())
        if vb is not None:
            if vb == 1.0:
                return a
            if vb == 0.0:
                return self.const(1.0)
            if vb == int(vb):
                return self._node("powi", a, self._cidx(vb))
            return self._node("powr", a, self._cidx(vb))
        return self._node("pow", a, b)

    def program(self, outputs: tuple, text: tuple) -> Program:
        """Prune to what the outputs use and renumber: constants, t, then the rest."""
        used = set()
        stack = list(outputs)
        while stack:
            k = stack.pop()
            if k in used:
                continue
            used.add(k)
            op, a, b = self.nodes[k]
            shape = OPS[op].shape
            if shape in ("unary", "binary", "power"):
                stack.append(a)
            if shape == "binary":
                stack.append(b)
        order = sorted(used, key=lambda k: (self.nodes[k][0] != "const",
                                            self.nodes[k][0] != "t", k))
        new = {k: i for i, k in enumerate(order)}
        consts, cnew = [], {}

        def cref(c):
            if c not in cnew:
                cnew[c] = len(consts)
                consts.append(self.consts[c])
            return cnew[c]
        ops, aa, bb = [], [], []
        for k in order:
            op, a, b = self.nodes[k]
            ops.append(op)
            shape = OPS[op].shape
            if shape == "const":
                ref = (cref(a), 0)
            elif shape == "t":
                ref = (0, 0)
            elif shape == "power":
                ref = (new[a], cref(b))
            elif shape == "harmonic":
                ref = (len(consts), 0)
                consts.extend(self.harmonic[k][1:])          # A, w, p consecutive
            elif shape == "binary":
                ref = (new[a], new[b])
            else:
                ref = (new[a], 0)
            aa.append(ref[0])
            bb.append(ref[1])
        return Program(tuple(ops), tuple(aa), tuple(bb), tuple(consts),
                       tuple(new[k] for k in outputs), text)


# ---- parsing -----------------------------------------------------------------------------
# the tokens, or any other character (one scan: every position matches one alternative)
_SCAN = re.compile(_TOKEN.pattern + r"| (?P<bad>[\s\S])", re.VERBOSE | re.ASCII)
_END = ("end", "", -1, -1)


def _tokens(text: str) -> list:
    """(kind, text, position from 1, end) of each token, and _END after the last."""
    out = []
    for m in _SCAN.finditer(text):
        kind = m.lastgroup
        if kind == "ws":
            continue
        if kind == "bad":
            ch, pos = m.group(), m.start()
            shown = repr(ch) if ch.isprintable() and ch.isascii() else f"U+{ord(ch):04X}"
            raise LawError(f"unexpected character {shown} at position {pos + 1} (laws are "
                           "ASCII: digits 0-9, t, pi, + - * / ** ^ ( ) and "
                           f"{', '.join(FUNCTIONS)})")
        out.append((kind, m.group(), m.start() + 1, m.end()))
    out.append(_END)
    return out


class _Span:
    """A span of a law's text; called, its text as a message quotes it.  (It holds the
    string, not the parser: a recorded tape keeps no parser alive.)"""
    __slots__ = ("src", "lo", "hi")

    def __init__(self, src: str, lo: int, hi: int):
        self.src, self.lo, self.hi = src, lo, hi

    def __call__(self) -> str:
        s = self.src[self.lo:self.hi].strip()
        return repr(s if len(s) <= 60 else s[:57] + "...")


class _Parser:
    def __init__(self, text: str, builder: _Builder):
        self.src = text
        self.tokens = _tokens(text)
        self.i = 0
        self.depth = 0
        self.b = builder

    def peek(self):
        return self.tokens[self.i]              # (the last is _END, never taken)

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
            raise LawError(f"is nested deeper than {MAX_DEPTH} levels")

    def span(self, start: int) -> "_Span":
        """The source text from token ``start`` to the current one, as a callable (its
        text only made when a message needs it)."""
        end = self.i
        lo = self.tokens[start][2] - 1
        return _Span(self.src, lo, self.tokens[end - 1][3] if end > start else lo)

    def expr(self) -> int:
        self.deeper()
        start = self.i
        left = self.term()
        while self.peek()[1] in ("+", "-"):
            op = self.take()[1]
            right = self.term()
            left = self.b.binary("add" if op == "+" else "sub", left, right, self.span(start))
        self.depth -= 1
        return left

    def term(self) -> int:
        start = self.i
        left = self.unary()
        while self.peek()[1] in ("*", "/"):
            op = self.take()[1]
            right = self.unary()
            left = self.b.binary("mul" if op == "*" else "div", left, right, self.span(start))
        return left

    def unary(self) -> int:
        if self.peek()[1] in ("+", "-"):
            op = self.take()[1]
            self.deeper()
            value = self.unary()
            self.depth -= 1
            return value if op == "+" else self.b.neg(value)
        return self.power()

    def power(self) -> int:
        start = self.i
        base = self.atom()
        if self.peek()[1] in ("**", "^"):
            self.take()
            self.deeper()
            exponent = self.unary()
            self.depth -= 1
            return self.b.power(base, exponent, self.span(start))
        return base

    def atom(self) -> int:
        kind, value, pos, _ = self.peek()
        start = self.i
        if kind == "number":
            self.take()
            number = float(value)
            if not math.isfinite(number):
                raise LawError(f"number {value!r} at position {pos} is not finite")
            if number == 0.0 and re.search(r"[1-9]", value.split("e")[0].split("E")[0]):
                raise LawError(f"number {value!r} at position {pos} underflows to zero")
            if 0.0 < abs(number) < 2.2250738585072014e-308:
                raise LawError(f"number {value!r} at position {pos} is subnormal")
            return self.b.const(number)
        if kind == "name":
            self.take()
            if value == "t":
                return self.b.t()
            if value == "pi":
                return self.b.const(math.pi)
            if value in FUNCTIONS:
                self.take("(")
                self.deeper()
                arg = self.expr()
                self.depth -= 1
                self.take(")")
                return self.b.call(value, arg, self.span(start))
            allowed = ", ".join(["t", "pi", *FUNCTIONS])
            shown = value if len(value) <= 20 else value[:17] + "..."
            raise LawError(f"unknown name {shown!r} at position {pos} (allowed: {allowed})")
        if value == "(":
            self.take()
            inner = self.expr()
            self.take(")")
            return inner
        where = f"position {pos}" if pos > 0 else "the end"
        raise LawError(f"expected a number, t, a function or '(' at {where}")


def parse_one(text: str, builder) -> int:
    """The node of ``text`` in ``builder`` (a :class:`_Builder`, or a :class:`_Recorder`)."""
    if not isinstance(text, str):
        raise LawError("must be a string")
    if len(text) > MAX_LENGTH:
        raise LawError(f"is longer than {MAX_LENGTH} characters ({len(text)})")
    if not text.strip():
        raise LawError("is empty")
    parser = _Parser(text, builder)
    node = parser.expr()
    if parser.i != len(parser.tokens) - 1:
        _, tok, pos, _ = parser.peek()
        raise LawError(f"unexpected {tok!r} at position {pos}")
    return node


# ---- a string parsed once: the builder's calls, replayed ---------------------------------
# The parser never reads what a builder returns but to hand it to a later call, so the
# calls it makes for a string are the same whatever the builder holds: recorded once
# (the tape), they are replayed into each builder that needs the string (a point's law,
# then the program of every body; a study's variants that share a coordinate).  The
# replay makes exactly the calls the parser would have made, in the same order: the same
# nodes, the same constants, the same refusals (a refusal of the parser's own, a
# malformed string, is raised where the parser raised it, after the calls before it).
class _Recorder:
    """A builder that only records: each call is (method, arguments) with the nodes it
    reads given as the positions of earlier calls, and returns its own position."""
    __slots__ = ("calls",)

    def __init__(self):
        self.calls: list = []

    def _add(self, call: tuple) -> int:
        self.calls.append(call)
        return len(self.calls) - 1

    def const(self, v: float) -> int:
        return self._add(("const", v))

    def t(self) -> int:
        return self._add(("t",))

    def binary(self, op: str, a: int, b: int, text) -> int:
        return self._add(("binary", op, a, b, text))

    def neg(self, a: int) -> int:
        return self._add(("neg", a))

    def call(self, name: str, a: int, text) -> int:
        return self._add(("call", name, a, text))

    def power(self, a: int, b: int, text) -> int:
        return self._add(("power", a, b, text))


@lru_cache(maxsize=4096)
def _tape(text: str) -> tuple:
    """(calls, node, refusal): the builder calls of ``text``, the position of its node,
    and the parser's refusal (None, or its message: raised after the calls before it)."""
    rec = _Recorder()
    try:
        node = parse_one(text, rec)
    except LawError as exc:
        return tuple(rec.calls), -1, str(exc)
    return tuple(rec.calls), node, None


def parse_into(text: str, b: _Builder) -> int:
    """The node of ``text`` in ``b``: as :func:`parse_one`, the string parsed once."""
    if not isinstance(text, str):
        raise LawError("must be a string")
    if len(text) > MAX_LENGTH:                # (not kept: the cache holds short strings)
        raise LawError(f"is longer than {MAX_LENGTH} characters ({len(text)})")
    calls, node, refusal = _tape(text)
    ids: list = []
    for call in calls:
        m = call[0]
        if m == "binary":
            k = b.binary(call[1], ids[call[2]], ids[call[3]], call[4])
        elif m == "const":
            k = b.const(call[1])
        elif m == "call":
            k = b.call(call[1], ids[call[2]], call[3])
        elif m == "t":
            k = b.t()
        elif m == "neg":
            k = b.neg(ids[call[1]])
        else:
            k = b.power(ids[call[1]], ids[call[2]], call[3])
        ids.append(k)
    if refusal is not None:
        raise LawError(refusal)
    return ids[node]


class CoordinateError(LawError):
    """A :class:`LawError` in coordinate ``k`` of the law."""

    def __init__(self, k: int, message: str):
        super().__init__(message)
        self.k = k


@lru_cache(maxsize=512)
def compile_law(texts: tuple) -> Program:
    """The program of a law given as three strings (cached by the text)."""
    if len(texts) != 3:
        raise LawError("must be three strings: x(t), y(t), z(t)")
    b = _Builder()
    outs = []
    for k, text in enumerate(texts):
        try:
            outs.append(parse_into(text, b))
        except CoordinateError:
            raise
        except LawError as exc:
            raise CoordinateError(k, str(exc)) from None
    return b.program(tuple(outs), tuple(texts))


@lru_cache(maxsize=512)
def compile_angle(text: str) -> Program:
    """The program of a rotor's angle psi(t), one string (one output; cached by the
    text)."""
    b = _Builder()
    return b.program((parse_into(text, b),), (text,))


@lru_cache(maxsize=64)
def compile_outputs(texts: tuple, limit: int) -> Program:
    """One program of many outputs, one per string (every point's x, y, z, every rotor's
    psi): one builder, so that a subexpression common to several bodies is one node; at
    most ``limit`` nodes in all.  The strings have been compiled one law at a time before
    (their own errors named there); CoordinateError(k) names the string otherwise."""
    b = _Builder(limit)
    outs = []
    for k, text in enumerate(texts):
        try:
            outs.append(parse_into(text, b))
        except LawError as exc:
            if str(exc).startswith("has more than"):
                raise LawError(f"have more than {limit} distinct operations together (the "
                               "runtime's law workspace)") from None
            raise CoordinateError(k, str(exc)) from None
    return b.program(tuple(outs), tuple(texts))


def parse_law(text: str) -> Program:
    """One coordinate as a program (x = the law, y = z = 0): for tests and tools."""
    return compile_law((text, "0", "0"))


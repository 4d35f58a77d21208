"""Operation counts and critical paths of a :class:`~derive.emit.program.Program`.

An integrator calls a right-hand side with a state that depends on the last call's
output, so the time per call in that loop is bounded below by the longest chain of
dependent operations from the state to the outputs (the law and the parameters do not
depend on the last output: what reads only them is off that chain).  This module walks
the program as the C printer writes it (sums and products evaluated left to right, in
SymPy's printing order; C compilers do not reassociate floating point) and reports, per
kind of operation, the counts in the whole program and along the longest chain, weighted
by the latencies of the machine (measured by ``derive bench rhs``).

The C printer orders the terms of each sum and the factors of each product by the time
their values are ready (:func:`readiness`, with :data:`NOMINAL` latencies): what reads
only the law and the parameters first, then what reads the state, earliest first.  C
evaluates ``a + b + c`` as ``(a + b) + c`` and compilers do not reassociate, so the
state's latest term then enters the sum last, one addition (or one fused multiply-add)
before the result, instead of waiting for terms that could have been summed long before.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from .program import HOT, Program

KINDS = ("add", "mul", "div", "sqrt", "call")
# cycles per dependent operation of a typical x86-64 core: only their order matters here
NOMINAL = {"add": 3.0, "mul": 3.0, "div": 13.0, "sqrt": 20.0, "call": 40.0}


def _ready_key(chain) -> float:
    return float("-inf") if chain is None else chain.time


@dataclass
class Chain:
    time: float
    counts: dict = field(default_factory=dict)

    def then(self, kind: str, latency: dict) -> "Chain":
        counts = dict(self.counts)
        counts[kind] = counts.get(kind, 0) + 1
        return Chain(self.time + latency[kind], counts)


def _later(a: Chain | None, b: Chain | None) -> Chain | None:
    if a is None:
        return b
    if b is None:
        return a
    return a if a.time >= b.time else b


class _Walker:
    """The chain of an expression as the C printer writes it: terms and factors in the
    order of :func:`readiness` (stable in SymPy's order among equals)."""

    def __init__(self, latency: dict, ready: dict):
        self.latency = latency
        self.ready = ready              # symbol -> Chain (None: independent of the state)
        self.totals = dict.fromkeys(KINDS, 0)

    def op(self, kind: str, *operands):
        self.totals[kind] += 1
        start = None
        for o in operands:
            start = _later(start, o)
        return start.then(kind, self.latency) if start is not None else None

    def __call__(self, expr):
        expr = sp.sympify(expr)
        if expr.is_Symbol:
            return self.ready.get(expr)
        if expr.is_Number or expr.is_NumberSymbol:
            return None
        if expr.is_Add:
            terms = sorted((self(t) for t in expr.as_ordered_terms()), key=_ready_key)
            acc = terms[0]
            for t in terms[1:]:
                acc = self.op("add", acc, t)
            return acc
        if expr.is_Mul:
            coeff, factors = expr.as_coeff_mul()
            factors = sorted((self(f) for f in sp.Mul(*factors).as_ordered_factors()),
                             key=_ready_key)
            acc = factors[0]
            if coeff not in (1, -1):
                acc = self.op("mul", acc)
            for f in factors[1:]:
                acc = self.op("mul", acc, f)
            return acc
        if expr.is_Pow:
            base, exp = self(expr.base), expr.exp
            if exp.is_Integer:
                k = int(exp)
                acc = base
                for _ in range(abs(k) - 1):
                    acc = self.op("mul", acc, base)
                return self.op("div", acc) if k < 0 else acc
            if exp == sp.Rational(1, 2):
                return self.op("sqrt", base)
            if exp == sp.Rational(-1, 2):
                return self.op("div", self.op("sqrt", base))
            return self.op("call", base, self(exp))
        if isinstance(expr, sp.Function):
            return self.op("call", *[self(a) for a in expr.args])
        raise NotImplementedError(f"latency of {expr.func}")


@dataclass
class Analysis:
    totals: dict          # operations of each kind in the program
    path: Chain           # the longest chain from the hot inputs to an output
    hot: tuple            # the names of the input vectors that start the chain

    @property
    def flops(self) -> int:
        return sum(self.totals.values())

    def describe(self) -> str:
        c = self.path.counts
        parts = [f"{c[k]} {k}" for k in KINDS if c.get(k)]
        return f"{sum(c.values())} ops ({', '.join(parts)})"


def analyse(program: Program, hot: tuple, latency: dict) -> Analysis:
    """Counts and the longest chain of ``program`` from the input vectors named in
    ``hot`` (the others are taken as ready long before), with ``latency[kind]`` the time
    of one dependent operation of each kind (any unit)."""
    ready = {}
    for vec, values in zip(program.spec.inputs, program.inputs):
        if vec.name in hot:
            for s in values:
                ready[s] = Chain(0.0, {})
    walker = _Walker(latency, ready)
    for sym, expr in program.steps:
        ready[sym] = walker(expr)
    longest = Chain(0.0, {})
    for out in program.outputs:
        for expr in out:
            longest = _later(longest, walker(expr)) or longest
    return Analysis(totals=walker.totals, path=longest, hot=tuple(hot))


def readiness(program: Program, hot: tuple = HOT, latency: dict | None = None):
    """``key(expr)``: when the value of ``expr`` is ready in a call of ``program`` with
    the inputs named in ``hot`` arriving at time 0 and the others long before
    (``-inf``), in :data:`NOMINAL` cycles.  The C printer sorts the terms of a sum and
    the factors of a product by it (stable: SymPy's order among equals)."""
    ready = {}
    for vec, values in zip(program.spec.inputs, program.inputs):
        if vec.name in hot:
            for s in values:
                ready[s] = Chain(0.0, {})
    walker = _Walker(latency or NOMINAL, ready)
    for position, (sym, expr) in enumerate(program.steps):
        chain = walker(expr)
        # among equals, what the program computes later is later (a tie broken by a
        # fraction of a cycle: the terms of a sum then enter in the program's order)
        ready[sym] = None if chain is None else Chain(chain.time + 1e-6 * position,
                                                      chain.counts)
    memo: dict = {}

    def key(expr) -> float:
        hit = memo.get(expr)
        if hit is None:
            hit = memo[expr] = _ready_key(walker(expr))
        return hit
    return key

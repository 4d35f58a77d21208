"""CasADi functions from :mod:`derive.models` specifications.

The SymPy expressions are translated node by node into CasADi SX (shared subtrees map
once), the solves with J use the same closed-form solve as the C (:mod:`derive.emit.linalg`), and
the function is built with CasADi's CSE and saved with ``Function.save``.
"""
from __future__ import annotations

from pathlib import Path

import casadi as ca
import sympy as sp

from ..models import FunctionSpec
from .linalg import SOLVERS, solve_values, solver_for

_FUNCTIONS = {sp.sin: ca.sin, sp.cos: ca.cos, sp.tan: ca.tan, sp.exp: ca.exp,
              sp.log: ca.log, sp.sinh: ca.sinh, sp.cosh: ca.cosh, sp.tanh: ca.tanh,
              sp.asin: ca.asin, sp.acos: ca.acos, sp.atan: ca.atan, sp.Abs: ca.fabs,
              sp.sign: ca.sign}


class Translator:
    """SymPy expression -> CasADi SX, memoised per node."""

    def __init__(self, table: dict):
        self.memo: dict = dict(table)

    def __call__(self, expr):
        expr = sp.sympify(expr)
        hit = self.memo.get(expr)
        if hit is not None:
            return hit
        value = self._translate(expr)
        self.memo[expr] = value
        return value

    def _translate(self, expr):
        if expr.is_Number:
            return ca.SX(float(expr))
        if expr.is_Symbol:
            raise KeyError(f"no CasADi value for the symbol {expr}")
        if expr.is_Add:
            args = [self(a) for a in expr.args]
            total = args[0]
            for a in args[1:]:
                total = total + a
            return total
        if expr.is_Mul:
            args = [self(a) for a in expr.args]
            total = args[0]
            for a in args[1:]:
                total = total * a
            return total
        if expr.is_Pow:
            base, exp = self(expr.base), expr.exp
            if exp.is_Integer:
                k = int(exp)
                if k == -1:
                    return 1 / base
                if k == 2:
                    return base * base
                return base ** k
            if exp == sp.Rational(1, 2):
                return ca.sqrt(base)
            if exp == sp.Rational(-1, 2):
                return 1 / ca.sqrt(base)
            return base ** self(exp)
        for cls in type(expr).__mro__:            # (derive.surfaces' sign is SymPy's)
            fn = _FUNCTIONS.get(cls)
            if fn is not None:
                return fn(*[self(a) for a in expr.args])
        raise NotImplementedError(f"no CasADi translation for {expr.func}")


def build_function(spec: FunctionSpec) -> ca.Function:
    inputs = [ca.SX.sym(v.name, len(v.entries)) for v in spec.inputs]
    table = {sym: inputs[i][k] for i, v in enumerate(spec.inputs)
             for k, sym in enumerate(v.entries)}
    tr = Translator(table)
    for sym, expr in spec.definitions:
        tr.memo[sym] = tr(expr)
    for solve in spec.solves:
        kind = solver_for(solve)
        tri = [tr(v) for v in solve_values(solve, kind)]
        rhs = [[tr(v) for v in vec] for vec in solve.rhs]
        for unknown, values in zip(solve.unknowns, SOLVERS[kind](tri, rhs)):
            for sym, val in zip(unknown, values):
                tr.memo[sym] = val
    outputs = [ca.vertcat(*[tr(v) for v in vec.entries]) for vec in spec.outputs]
    return ca.Function(spec.name, inputs, outputs, [v.name for v in spec.inputs],
                       [v.name for v in spec.outputs], {"cse": True})


def render_casadi(specs: list[FunctionSpec]) -> dict[str, bytes]:
    """``casadi/<name>.casadi`` for every spec, as bytes."""
    import tempfile
    files: dict[str, bytes] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for spec in specs:
            path = Path(tmp) / f"{spec.name}.casadi"
            build_function(spec).save(str(path))
            files[f"casadi/{spec.name}.casadi"] = path.read_bytes()
    return files

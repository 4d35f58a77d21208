"""C99 expression printer for the generated code.

SymPy's C99 printer with the habits of hand-written numerical C: small integer powers
as products, ``sqrt`` for half powers, reciprocals as ``1.0/x``, floats printed so that
they round-trip exactly, and symbols printed through a name table (``q[3]``, ``_c12``).
"""
from __future__ import annotations

import math

import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import PRECEDENCE, precedence


class CPrinter(C99CodePrinter):
    def __init__(self, names: dict):
        super().__init__()
        self._names = names

    def _print_Symbol(self, expr):
        try:
            return self._names[expr]
        except KeyError:
            raise KeyError(f"no C name for the symbol {expr}") from None

    def _print_Float(self, expr):
        return repr(float(expr))

    def _print_Pi(self, expr):          # M_PI is POSIX, not C99
        return repr(math.pi)

    def _print_Exp1(self, expr):
        return repr(math.e)

    def _print_Rational(self, expr):
        return f"({expr.p}.0/{expr.q}.0)"

    def _print_Integer(self, expr):
        return f"{int(expr)}.0" if abs(int(expr)) < 2**53 else repr(float(expr))

    def _print_Mul(self, expr):
        # SymPy prints x*y**-2 as "x/" + the denominator y**2, which _print_Pow writes
        # as the product "y*y": "x/y*y" would divide once and multiply once.  Such
        # denominators are printed through a placeholder that stands for "(y*y)".
        subs = {}
        for k, factor in enumerate(expr.args):
            if factor.is_Pow and factor.exp.is_Integer and -4 <= factor.exp <= -2:
                hold = sp.Symbol(f"_denominator{k}")
                self._names[hold] = f"({self._print(sp.Pow(factor.base, -factor.exp))})"
                subs[factor] = 1 / hold
        if not subs:
            return super()._print_Mul(expr)
        try:
            return super()._print_Mul(expr.xreplace(subs))
        finally:
            for value in subs.values():
                self._names.pop(1 / value, None)

    def _print_Pow(self, expr):
        base, exp = expr.base, expr.exp
        prec = precedence(expr)
        b = self.parenthesize(base, PRECEDENCE["Mul"] + 1)
        if exp.is_Integer:
            k = int(exp)
            if 1 <= k <= 4:
                return "*".join([b] * k)
            if -4 <= k <= -1:
                prod = "*".join([b] * (-k))
                return f"1.0/({prod})" if -k > 1 else f"1.0/{b}"
        if exp == sp.Rational(1, 2):
            return f"sqrt({self._print(base)})"
        if exp == sp.Rational(-1, 2):
            return f"1.0/sqrt({self._print(base)})"
        if exp == sp.Rational(3, 2):
            return f"({b}*sqrt({self._print(base)}))"
        if exp == sp.Rational(-3, 2):
            return f"1.0/({b}*sqrt({self._print(base)}))"
        return f"pow({self._print(base)}, {self.parenthesize(exp, prec)})"


def c_expression(expr, names: dict) -> str:
    return CPrinter(names).doprint(expr)

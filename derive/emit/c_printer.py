"""C99 expression printer for the generated code.

SymPy's C99 printer with the habits of hand-written numerical C: small integer powers
as products, ``sqrt`` for half powers, reciprocals as ``1.0/x``, floats printed so that
they round-trip exactly, and symbols printed through a name table (``q[3]``, ``_c12``).
With a ``rank`` (:func:`derive.emit.latency.readiness`) the terms of a sum and the
factors of a product are printed in the order their values are ready, the state's last.
"""
from __future__ import annotations

import math

import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import PRECEDENCE, precedence


class CPrinter(C99CodePrinter):
    def __init__(self, names: dict, rank=None):
        super().__init__()
        self._names = names
        self._rank = rank

    def _as_ordered_terms(self, expr, order=None):
        terms = expr.as_ordered_terms()
        if not self._rank:
            return terms
        terms = sorted(terms, key=self._rank)
        # A compiler that contracts a*b + c*d into one fused multiply-add takes the
        # first product into it and computes the second one before: the later of the
        # two first terms goes first, so that it waits for one operation, not two.
        if len(terms) > 1 and _is_product(terms[0]) and _is_product(terms[1]):
            terms[0], terms[1] = terms[1], terms[0]
        return terms

    def _ranked_mul(self, expr):
        """``expr`` with its factors in the order of ``rank`` (the coefficient first),
        for the base printer with the setting ``order='none'``."""
        coeff, rest = expr.as_coeff_Mul()
        factors = sorted(rest.as_ordered_factors(), key=self._rank)
        args = ([] if coeff == 1 else [coeff]) + factors
        return sp.Mul(*args, evaluate=False) if len(args) > 1 else args[0]

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
            return self._print_ordered_mul(expr)
        try:
            return self._print_ordered_mul(expr.xreplace(subs))
        finally:
            for value in subs.values():
                self._names.pop(1 / value, None)

    def _print_ordered_mul(self, expr):
        if not self._rank:
            return super()._print_Mul(expr)
        ranked = self._ranked_mul(expr)
        if not ranked.is_Mul:
            return self._print(ranked)
        order = self._settings["order"]
        self._settings["order"] = "none"
        try:
            return super()._print_Mul(ranked)
        finally:
            self._settings["order"] = order

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


def _is_product(term) -> bool:
    """Whether ``term`` prints as a multiplication in C (``-x`` and ``x*y/z`` do not)."""
    if term.is_Pow:
        return term.exp.is_Integer and 2 <= term.exp <= 4
    if not term.is_Mul:
        return False
    coeff, rest = term.as_coeff_Mul()
    factors = rest.as_ordered_factors()
    if any(f.is_Pow and f.exp.is_negative for f in factors):
        return False                                  # printed as a quotient
    return len(factors) + (coeff not in (1, -1)) > 1 or any(_is_product(f) for f in factors)


def c_expression(expr, names: dict, rank=None) -> str:
    return CPrinter(names, rank).doprint(expr)

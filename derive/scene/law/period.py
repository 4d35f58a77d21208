"""The common period of laws given as formulas: every sin/cos argument ``k t + c`` with
frequencies commensurate (ratios of small integers), and t nowhere else.  Read by the
stability analysis (its Floquet period) and by a base run's mean velocity per period."""
from __future__ import annotations

import math
from fractions import Fraction

import sympy as sp

from ... import notation as nt


class NotPeriodic(ValueError):
    """``constant``: the laws have no frequency at all; else why they are not periodic."""

    def __init__(self, why: str, constant: bool = False):
        super().__init__(why)
        self.constant = constant


def common_period(exprs) -> float:
    """The least common period of SymPy expressions in ``derive.notation.t``, or
    :class:`NotPeriodic`."""
    freqs = set()
    for expr in exprs:
        expr = sp.sympify(expr)
        for atom in expr.atoms(sp.sin, sp.cos):
            arg = sp.expand(atom.args[0])
            k = arg.coeff(nt.t)
            if not k.is_number or (arg - k * nt.t).has(nt.t):
                raise NotPeriodic(f"is not periodic in t ({atom})")
            if k != 0:
                freqs.add(abs(float(k)))
        if expr.xreplace({a: 0 for a in expr.atoms(sp.sin, sp.cos)}).has(nt.t):
            raise NotPeriodic(f"is not periodic in t ({expr})")
    if not freqs:
        raise NotPeriodic("a constant law has no period", constant=True)
    base = min(freqs)
    ratios = [Fraction(f / base).limit_denominator(64) for f in freqs]
    for f, r in zip(freqs, ratios):
        if abs(f / base - float(r)) > 1e-12:
            raise NotPeriodic("has incommensurate frequencies")
    den = math.lcm(*[r.denominator for r in ratios])
    return 2 * math.pi / (base / den)

"""The system the carrier's equations are derived for, as the momentum theorems see it.

The theorems of momentum and angular momentum (E1.1) see what the carrier carries only
through the total mass ``m + M``, the centre of mass C (``OC`` in body axes, a function of
time) and the angular momentum about C, ``K = J(t) omega + k(t)``: affine in omega, with
``J`` the inertia of the whole about C as if locked and ``k`` what the internal motion
adds.  Flight (:mod:`derive.momentum`), impact (:mod:`derive.impact`), persistent contact
(:mod:`derive.contact`) and the rough plane (:mod:`derive.friction`) are derived once in
these terms, for a :class:`System`:

* the paper's, one point P of mass m on a prescribed law OP(t)
  (:func:`derive.momentum.point_system`: E1.4–E1.6 from the definition of K about C);
  E1.4–E1.16 are this instance, and every function of those modules takes it when called
  without a system;
* the moments of any number of points and rotors (:func:`derive.moments.moments_system`),
  which ``paper_checks`` (X1.2) proves equal to the first for one point.

What a system must say: ``oc`` (OC as time functions: the derivations differentiate it),
its angular momentum (:class:`AngularMomentum`) and ``law_rates``, the chain rule of its
internal motion (each frozen symbol of the law and its rate).  The total mass is ``m + M``
for both: ``m`` is the points' total mass (derive/layout.py's MOMENTS).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp


@dataclass(frozen=True)
class AngularMomentum:
    K: sp.Matrix          # K about C, body axes, frozen symbols (the point: E1.6, with mu)
    J: sp.Matrix          # dK/d omega (the point: E1.5)
    own: sp.Matrix        # K - J omega: the part carried by the internal motion
    K_definition: sp.Matrix   # straight from the definition, in M and m
    K_vector: sp.Matrix   # the same K kept factored (cross products), for the code


@dataclass(frozen=True, eq=False)
class System:
    """What the derivations read of the system (equality and hashing by identity: each
    system is built once, and the derivations are cached per system)."""
    name: str
    oc: sp.Matrix                 # OC in body axes, as time functions (derive.notation)
    momentum: AngularMomentum
    law_rates: tuple              # ((symbol, its rate), ...) of the internal motion

    def law_rate(self, expr):
        """d/dt of an expression in the internal motion's symbols and nothing else
        moving (the chain rule over :attr:`law_rates`)."""
        return sum((sp.diff(expr, s) * r for s, r in self.law_rates), sp.Integer(0))

    def rates(self) -> dict:
        return dict(self.law_rates)

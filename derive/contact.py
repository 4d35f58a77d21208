"""Persistent contact: S stays on the smooth plane under a normal reaction N >= 0.

When impacts accumulate (e < 1) the carrier comes to rest on the plane, sliding freely
(the plane is smooth).  The same momentum theorems as in flight (E1.1), now with the
force ``N e_Z`` applied at the body point S:

    (m + M) dV_C/dt = -(m + M) g e_Z + N e_Z
    dK/dt = CS x (N n) = N d                       (d of E1.10)

and the constraint that S stays on the plane, ``h = 0``: its rate is ``v_n`` (E1.14)
and must stay zero, ``dv_n/dt = 0``.  ``v_n`` is affine in ``Z_C'`` and ``omega``
(coefficients 1 and ``d``), so ``dv_n/dt = Z_C'' + (d, omega') + rest``; with
``omega' = J^-1 f + N J^-1 d`` and ``Z_C'' = -g + N/(m+M)`` it is
``a_free + N k`` with the ``k`` of E1.16, and

    N = -a_free / k.

S moves over the surface as the body turns (``OS`` depends on ``n``), so ``rest``
contains the rate of ``OS``; it enters as the input ``OS_rate`` (see
:mod:`derive.surfaces` for its value on a sphere or an ellipsoid).  Lift-off is where N
would turn negative.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from . import notation as nt
from .impact import impact_map, lever
from .kinematics import poisson_equations
from .momentum import flight_dynamics_structured, per_system
from .system import System

A_FREE = sp.Symbol("a_free", real=True)     # dv_n/dt with N = 0


@dataclass(frozen=True)
class ContactDynamics:
    a_free: sp.Expr          # dv_n/dt at N = 0, in terms of omega' (unknown) and inputs
    v_n_rate_coefficients: tuple   # (coefficient of Z_C'', coefficients of omega')
    normal_force: sp.Expr    # N = -a_free/k, in terms of A_FREE and the k of E1.16
    z_acceleration: sp.Expr  # Z_C'' = -g + N/(m+M)
    omega_rhs: tuple         # (f, d): J omega' = f + N d


@per_system
def contact_dynamics(system: System) -> ContactDynamics:
    """For any :class:`~derive.system.System` (the paper's when called without one): the
    rates of its internal motion enter through ``system.law_rates``."""
    im = impact_map(system)
    v_n = im.normal_velocity
    _, d = lever(system)
    fd = flight_dynamics_structured(system)
    # momentum theorems with N at S
    N = nt.N
    z_acc = sp.solve(sp.Eq((nt.m + nt.M) * nt.Z_Cdd, -(nt.m + nt.M) * nt.g + N), nt.Z_Cdd)[0]
    # dv_n/dt along the motion: chain rule over every quantity v_n depends on
    poisson = poisson_equations()
    rates = {nt.Z_Cd: nt.Z_Cdd,
             **dict(zip(nt.omega, nt.omega_dot)),
             **{nt.a[2, j]: poisson[2, j] for j in range(3)},
             **system.rates(),
             **dict(zip(nt.OS, nt.OS_rate))}
    v_n_rate = sum((sp.diff(v_n, s) * r for s, r in rates.items()), sp.Integer(0))
    c_z = sp.diff(v_n_rate, nt.Z_Cdd)
    c_w = sp.Matrix([sp.diff(v_n_rate, w) for w in nt.omega_dot])
    if sp.simplify(c_z - 1) != 0 or (c_w - d).applyfunc(sp.expand) != sp.zeros(3, 1):
        raise AssertionError("dv_n/dt is not Z_C'' + (d, omega') + rest")
    # with N = 0: Z_C'' = -g, omega' = the flight solution (kept as the unknown omega')
    a_free = sp.expand(v_n_rate.xreplace({nt.Z_Cdd: z_acc.xreplace({N: 0})}))
    # with N: a_free + N (1/(m+M) + (d, w)) = a_free + N k; solve dv_n/dt = 0 for N
    from .impact import K_SYMBOL
    normal_force = sp.solve(sp.Eq(A_FREE + N * K_SYMBOL, 0), N)[0]
    k_check = sp.expand(1 / (nt.m + nt.M) + (d.T * nt.W)[0] - im.k)
    if k_check != 0:
        raise AssertionError("the contact coefficient differs from E1.16's k")
    return ContactDynamics(a_free=a_free, v_n_rate_coefficients=(c_z, tuple(c_w)),
                           normal_force=normal_force, z_acceleration=z_acc,
                           omega_rhs=(fd.forcing, d))

"""Reduced descriptions the runtime uses when a scene needs no more (sections 3 and 4).

* Axisymmetric carrier (``J_x = J_y``) with P on its axis (``x = y = 0``): Euler angles
  ``psi, theta, phi`` of the body relative to axes whose third axis is along the
  constant K.  With K of E1.6 specialised, ``theta`` is constant and ``psi'``, ``phi'``
  follow from ``omega = (skew^-1)(R^T R')`` and ``K_body = K R[2, :]`` (E3.11–E3.14).
* Plane motion (``z = 0``, ``omega_x = omega_y = 0``): ``K_z`` (the integral of E4.1)
  solved for ``omega_z``.

Everything here is computed from :mod:`derive.momentum`; ``paper_checks`` compares it
with the printed (3.11)–(3.14) and (4.2).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import sympy as sp

from . import notation as nt
from .momentum import angular_momentum

psi_t = sp.Function("psi", real=True)(nt.t)
phi_t = sp.Function("phi", real=True)(nt.t)
theta_t = sp.Function("theta", real=True)(nt.t)
theta0 = sp.Symbol("theta_0", real=True)
K_norm = sp.Symbol("K", positive=True)         # |K|, constant in flight
omega_z0 = sp.Symbol("omega_z0", real=True)     # omega_z, constant here (E3.6)
psi, phi = sp.symbols("psi phi", real=True)
psi_d, phi_d = sp.symbols("psi' phi'", real=True)


def _Rz(a):
    return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])


def _Rx(a):
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])


def euler_rotation(psi_, theta_, phi_) -> sp.Matrix:
    """Body -> axes along K: ``Rz(psi) Rx(theta) Rz(phi)``."""
    return _Rz(psi_) * _Rx(theta_) * _Rz(phi_)


@dataclass(frozen=True)
class Axisymmetric:
    K_body: sp.Matrix        # E1.6 specialised: ((J_x + mu z^2) omega_x, ..., J_z omega_z)
    k_direction: sp.Matrix   # the unit vector along K in body axes, at theta = theta0
    omega: sp.Matrix         # omega through psi', phi' at theta = theta0 (E3.12)
    cos_theta0: sp.Expr      # E3.11
    psi_rate: sp.Expr        # E3.14
    phi_rate: sp.Expr        # E3.14


@lru_cache(maxsize=None)
def axisymmetric() -> Axisymmetric:
    t = nt.t
    K = angular_momentum().K
    on_axis = {nt.x: 0, nt.y: 0, nt.xd: 0, nt.yd: 0, nt.xdd: 0, nt.ydd: 0, nt.J_y: nt.J_x}
    K3 = K.xreplace(on_axis).applyfunc(sp.factor)
    R = euler_rotation(psi_t, theta_t, phi_t)
    Om = (R.T * R.diff(t)).applyfunc(sp.simplify)
    omega = sp.Matrix([Om[2, 1], Om[0, 2], Om[1, 0]])
    frozen = {sp.Derivative(theta_t, t): 0, sp.Derivative(psi_t, t): psi_d,
              sp.Derivative(phi_t, t): phi_d}
    omega = omega.xreplace(frozen).xreplace({theta_t: theta0, psi_t: psi, phi_t: phi})
    omega = omega.applyfunc(sp.simplify)
    k_dir = R[2, :].T.xreplace({theta_t: theta0, psi_t: psi, phi_t: phi})
    # K_z = J_z omega_z = |K| cos(theta): theta constant (E3.11)
    cos0 = sp.solve(sp.Eq(K_norm * k_dir[2], K3[2].xreplace({nt.omega_z: omega_z0})),
                    sp.cos(theta0))[0]
    # K_x = |K| k_x with omega of the Euler angles, and omega_z = omega_z0
    eqs = [K3[0].xreplace({nt.omega_x: omega[0]}) - K_norm * k_dir[0], omega[2] - omega_z0]
    sol = sp.solve(eqs, [psi_d, phi_d], dict=True)[0]
    psi_rate = sp.simplify(sol[psi_d])
    phi_rate = sp.simplify(sol[phi_d].xreplace({sp.cos(theta0): cos0}))
    return Axisymmetric(K_body=K3, k_direction=k_dir, omega=omega, cos_theta0=cos0,
                        psi_rate=psi_rate, phi_rate=phi_rate)


@dataclass(frozen=True)
class Planar:
    K_z: sp.Expr        # E4.2's integral: K_z with z = 0, omega_x = omega_y = 0
    omega_z: sp.Expr    # omega_z solved from K_z = kappa
    kappa: sp.Symbol


@lru_cache(maxsize=None)
def planar() -> Planar:
    kappa = sp.Symbol("kappa", real=True)
    in_plane = {nt.z: 0, nt.zd: 0, nt.zdd: 0, nt.omega_x: 0, nt.omega_y: 0}
    Kz = sp.expand(angular_momentum().K[2].xreplace(in_plane))
    omega_z = sp.solve(sp.Eq(Kz, kappa), nt.omega_z)[0]
    return Planar(K_z=Kz, omega_z=sp.factor(omega_z), kappa=kappa)

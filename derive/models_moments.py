"""The ``moments`` family: the general model's functions for a carrier with any number of
points and rotors, which it sees through their moments (derive/layout.py's MOMENTS,
derived in :mod:`derive.moments`), and each body's share of those moments.

The state is the general model's (18), ``p = (M, m, J_x, J_y, J_z, g)`` with ``m`` the
points' total mass, and ``u`` the 27 moments in place of the one point's law.  Each
function is the general one's derivation (derive.momentum, derive.impact, derive.contact,
derive.friction) applied to :func:`derive.moments.moments_system`; J is a full symmetric
3x3 matrix here, solved numerically on its entries (derive.emit.linalg's adjugate).

* ``point_moments(mass, jet) -> moments``: a point's share (jet in u's order of
  derive/layout.py: ``x, y, z, x', y', z', x'', y'', z''``);
* ``rotor_moments(axis, inertia, rate) -> spin``: a rotor's share of ``(h, h')``,
  ``rate = (psi', psi'')``;
* ``moments_flight_rhs(q, u, p) -> dq``: E1.2, E1.7 of the moments in Euler's form
  (derive.moments.flight_form), E1.8;
* ``moments_gap``, ``moments_impact``, ``moments_contact_rhs``, ``moments_kinetic_moment``
  (K about C, body axes), ``moments_fixed_kinetic_moment`` (fixed axes),
  ``moments_omega``, ``moments_lie_stage``, ``moments_lie_point``: as the general ones;
* the rough plane's ``moments_delassus``, ``moments_contact_velocity``,
  ``moments_apply_impulse``, ``moments_sliding_rhs``, ``moments_sticking_rhs``,
  ``moments_contact_wrench``, ``moments_wrench_rhs`` (derive.friction_models).
"""
from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

from . import friction_models, layout
from . import models as dm
from . import moments as mm
from . import notation as nt
from .models import Family, FunctionSpec, LinearSolve, Vector

MODEL = "general"
U = Vector("u", mm.MOMENTS, layout.MOMENTS_LABELS)


def _solve(rhs: tuple, unknowns: tuple) -> LinearSolve:
    """``J x = b`` with J = J_O + Theta - (|s|^2 E - s s^T)/(m+M) by its entries (reading
    the named OC = s/(m+M), derive.moments.flight_form)."""
    return LinearSolve(matrix=mm.flight_form().matrix, rhs=rhs, unknowns=unknowns)


@lru_cache(maxsize=None)
def family() -> Family:
    return Family(prefix="moments", system=mm.moments_system(), u=U, solve=_solve,
                  definitions=mm.flight_form().definitions, mass_definitions=())


@lru_cache(maxsize=None)
def flight_rhs() -> FunctionSpec:
    """``moments_flight_rhs(q, u, p) -> dq``."""
    form = mm.flight_form()
    rates = dm._rates(MODEL)
    dq = tuple(rates[s] for s in dm.STATES[MODEL])
    return FunctionSpec(
        name="moments_flight_rhs",
        doc="Flight right-hand side with the internal motion as its moments: dq/dt (E1.2, "
            "E1.7 of the moments solved for omega' (derive.moments.flight_form), E1.8).",
        inputs=(dm._q(MODEL), U, dm._p()),
        outputs=(Vector("dq", dq, tuple(f"d({lb})/dt" for lb in dm.STATE_LABELS[MODEL])),),
        solves=(_solve((form.forcing,), (nt.omega_dot,)),), definitions=form.definitions)


@lru_cache(maxsize=None)
def point_moments() -> FunctionSpec:
    """``point_moments(mass, jet) -> moments``."""
    share = mm.point_share()
    return FunctionSpec(
        name="point_moments",
        doc="A point's share of the moments (derive.moments.point_share): m rho, its rates, "
            "m (|rho|^2 E - rho rho^T) and its rate (upper triangles), m rho x rho' and "
            "m rho x rho''; the moments are the sum over the points and rotors.",
        inputs=(Vector("mass", (mm.m_j,), ("m_j",)),
                Vector("jet", share.inputs, layout.POINT_JET_LABELS)),
        outputs=(Vector("moments", share.values, layout.MOMENTS_LABELS),))


@lru_cache(maxsize=None)
def rotor_moments() -> FunctionSpec:
    """``rotor_moments(axis, inertia, rate) -> spin``."""
    share = mm.rotor_share()
    return FunctionSpec(
        name="rotor_moments",
        doc="A rotor's share of the moments (derive.moments.rotor_share): I psi' a and "
            "I psi'' a, added to h and h' (derive/layout.py's MOMENTS.spin).",
        inputs=(Vector("axis", tuple(mm.ROTOR_AXIS), layout.ROTOR_AXIS_LABELS),
                Vector("inertia", (mm.I_AXIAL,), ("I",)),
                Vector("rate", (mm.PSI_D, mm.PSI_DD), layout.ROTOR_RATE_LABELS)),
        outputs=(Vector("spin", share.of("spin"),
                        layout.MOMENTS_LABELS[layout.MOMENTS.spin]),))


def moments_specs() -> list[FunctionSpec]:
    """Every function of the family, in the order ``derive emit`` renders them."""
    fam = family()
    return [point_moments(), rotor_moments(), flight_rhs(), dm.gap(MODEL, fam),
            dm.impact(MODEL, fam), dm.contact_rhs(MODEL, fam), dm.kinetic_moment(MODEL, fam),
            dm.fixed_kinetic_moment(fam), dm.momentum_omega(fam), dm.lie_stage(fam),
            dm.lie_point(fam),
            # the rough plane's modes switch at events: no jac_ (a planner has no use for
            # it, and it would double the time of derive emit)
            *(replace(spec, jacobian=False) for spec in friction_models.family_specs("moments"))]


def emitted_specs() -> list[FunctionSpec]:
    """What ``derive emit`` writes to generated/c and generated/casadi: the paper's
    models' functions (derive.models.all_specs), then this family's."""
    return dm.all_specs() + moments_specs()

"""Dynamics of a rigid body carrying a moving material point and bouncing on a plane
(Markeev 2012): derivation, proofs, code generation, simulation, measurement.

``derive.simulate(scene)`` runs a scene (a TOML path or a dict of the scene schema) and
returns a :class:`~derive.runtime.driver.Result`.
"""
from __future__ import annotations


def simulate(scene, progress: bool = True):
    """Simulate a scene; see :func:`derive.runtime.driver.simulate`."""
    from .runtime.driver import simulate as _simulate
    return _simulate(scene, progress=progress)


from .plan import plan  # noqa: E402  derive.plan(task) -> Plan (CasADi loads on the first call)

__all__ = ["simulate", "plan"]

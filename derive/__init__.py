"""Dynamics of a rigid body carrying a moving material point and bouncing on a plane
(Markeev 2012): derivation, proofs, code generation, simulation, measurement.

``derive.simulate(scene)`` runs a scene (a TOML path, a dict of the scene schema or a
parsed :class:`~derive.runtime.scene.Scene`) and returns a
:class:`~derive.runtime.driver.Result`; ``derive.simulate_many(scene, variants)`` runs
many variants of one scene for parameter studies.  Importing ``derive`` loads neither
SymPy nor CasADi: the runtime is precompiled C.
"""
from __future__ import annotations


def simulate(scene, progress: bool = False):
    """Simulate a scene; see :func:`derive.runtime.driver.simulate`."""
    from .runtime.driver import simulate as _simulate
    return _simulate(scene, progress=progress)


def simulate_many(scene, variants, **kwargs):
    """Run variants of a scene; see :func:`derive.runtime.batch.simulate_many`."""
    from .runtime.batch import simulate_many as _many
    return _many(scene, variants, **kwargs)


__all__ = ["simulate", "simulate_many"]

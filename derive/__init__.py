"""Dynamics of a rigid body carrying a moving material point and bouncing on a plane
(Markeev 2012): derivation, proofs, code generation, simulation, measurement.

``derive.simulate(scene)`` runs a scene (a TOML path, a dict of the scene schema or a
parsed :class:`~derive.scene.Scene`) and returns a
:class:`~derive.runtime.driver.Result`; ``derive.simulate_many(scene, variants)`` runs
many variants of one scene for parameter studies; ``derive.plan(task)`` plans the
point's motion (:mod:`derive.planner`); ``derive.control(task)`` closes the loop
around it on a disturbed plant (:mod:`derive.control`).  Importing ``derive`` loads neither
SymPy nor CasADi: the runtime is precompiled C.
"""
from __future__ import annotations


def simulate(scene, progress: bool = False):
    """Simulate a scene as its tables ask: in closed loop with ``[control]``, with the
    pushes of a ``[disturbance]``, else the plain run (:func:`derive.runtime.driver.
    simulate`); see :func:`derive.control.run.run_scene`."""
    from .control.run import run_scene
    return run_scene(scene, progress=progress)


def simulate_many(scene, variants, **kwargs):
    """Run variants of a scene; see :func:`derive.runtime.batch.simulate_many` (a scene
    with [control] or [disturbance]: :func:`derive.control.run.run_many`)."""
    from .control.run import run_many
    return run_many(scene, variants, **kwargs)


def plan(task, **kwargs):
    """Plan the point's motion for a task; see :func:`derive.planner.core.plan` (CasADi
    loads on the first call)."""
    from .planner.core import plan as _plan
    return _plan(task, **kwargs)


def control(task, **kwargs):
    """Close the loop of a control task (a plan task with [control] and [disturbance]);
    see :func:`derive.control.core.control` (CasADi loads on the first call)."""
    from .control.core import control as _control
    return _control(task, **kwargs)


__all__ = ["simulate", "simulate_many", "plan", "control"]

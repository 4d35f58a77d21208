"""Planning the point's motion with optimal control (issue 14).

``derive.plan(task) -> Plan``: a task is a scene with a ``[plan]`` table (goal reorient,
land or hop) instead of a point law; the planner transcribes it by direct multiple
shooting over the derived CasADi functions, solves it with IPOPT, makes it exact by
defect correction, writes the law as a table, a scene, C and plots, and re-simulates the
scene to measure what it achieves.  Modules, upstream first: ``task`` (parsing), ``law``
(the C^2 B-spline), ``functions`` (the derived CasADi functions), ``transcribe`` (the
NLP; the limits as parameters), ``guess``, ``resim`` (re-simulation, on the SciPy peer of
:mod:`derive.scipy_hybrid`), ``stability`` (a hop's multipliers), ``solve`` (one IPOPT
instance per task, defect correction), ``continuation`` (a loose acceleration bound
approached from a working one), ``diagnose`` (which limit blocks an infeasible task),
``goals`` (one object per goal: what differs between reorient, land and hop),
``summary`` (plan.json), ``outputs`` (the files), ``cemit`` (law.c, law.h), ``core``
(the pipeline), ``cli``.  The travel goal (the fastest periodic crawl of a body on its
face) has no NLP: ``travel`` searches a class of laws with the base model's C runtime,
``travel_scene`` builds the scene it runs and writes.

Importing this package is cheap; CasADi and SciPy load on the first call.
"""
from __future__ import annotations


def plan(task, progress: bool = False, runtime: bool = True):
    """Plan the point's law for a task (a TOML path, a dict of the task schema or a
    :class:`~derive.planner.task.Task`); returns a :class:`~derive.planner.core.Plan` whose
    ``summary`` (a :class:`~derive.planner.summary.Summary`; ``summary.to_dict()``) is
    plan.json and whose ``write(dir)`` writes every output.  Silent unless ``progress``
    (one line per IPOPT iteration on stderr)."""
    from .core import plan as _plan
    return _plan(task, progress=progress, runtime=runtime)


__all__ = ["plan"]

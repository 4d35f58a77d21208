"""The scene a ``travel`` plan runs and writes: the task's body resting on its face, the
point on its guide, the floor's friction, the carrier at rest at the start.

One builder for the document the search evaluates (the law as ``samples``) and the one it
writes (``law.csv``, the same rows): only numbers and the fixed strings of the schema are
written (the task's own strings, its name included, are not copied).  The task's parser
builds it too, with the point held at the guide's middle, so that a task the base model
cannot run is refused before any search.
"""
from __future__ import annotations

from .. import shapes
from ..scene import toml


def scene_document(sc, point: dict, duration: float) -> dict:
    """The scene of task scene ``sc`` with ``point`` ({'law': ...} or {'table': ...,
    'ends': 'periodic'} or {'samples': ..., 'ends': 'periodic'}), run for ``duration``."""
    body = {"mass": sc.M, "inertia": list(sc.J), "shape": sc.shape}
    body.update(shapes.fields_of(shapes.of(sc.shape), sc.size))
    body["center"] = list(sc.center)
    plane = {"friction": sc.friction}
    if sc.static_friction is not None:
        plane["static_friction"] = sc.static_friction
    if sc.pressure is not None:
        plane["pressure"] = sc.pressure
    return {"name": "planned-travel", "body": body, "point": {"mass": sc.m, **point},
            "plane": plane,
            "initial": {"time": sc.t0, "com": [float(sc.com[0]), float(sc.com[1]), 0.0],
                        "on_plane": True, "carrier_velocity": [0.0, 0.0, 0.0],
                        "matrix": [[float(a) for a in row] for row in sc.A0]},
            "run": {"duration": duration, "g": sc.g}}


def scene_toml(doc: dict) -> str:
    return toml.dumps(doc, ("Planned by `derive plan` (goal travel): the task's body on its "
                            "face with the fastest law found, as a periodic table.",
                            "`derive simulate scene.toml` runs it (the base model); its "
                            "summary's travel is the plan's mean velocity."))

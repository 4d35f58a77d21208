"""The plant a controller acts on: the scene with its ``[disturbance]`` (a heavier body,
other moments of inertia, another restitution), and the loop's noise and pushes.

The controller keeps the model's numbers (the scene as written); the plant is the scene
with the disturbance's factors applied, validated again like any scene (a factor that
makes the body impossible is refused naming ``[disturbance]``).
"""
from __future__ import annotations

import copy

import numpy as np

from ..runtime.loop import Loop
from ..scene import Scene, SceneError, parse_scene
from ..scene.scene import Disturbance


def plant_doc(doc: dict, disturbance: Disturbance | None) -> dict:
    """A scene's dict with the disturbance's factors applied (the model's dict unchanged)."""
    d = copy.deepcopy(doc)
    if disturbance is None:
        return d
    body = d["body"]
    body["mass"] = float(body["mass"]) * disturbance.mass_factor
    points = d.get("point", [])
    for point in points if isinstance(points, list) else [points]:   # [point], [[point]]
        point["mass"] = float(point["mass"]) * disturbance.point_mass_factor
    body["inertia"] = [float(j) * f for j, f in zip(body["inertia"],
                                                     disturbance.inertia_factor)]
    if disturbance.restitution is not None and "plane" in d:
        d["plane"]["restitution"] = disturbance.restitution
    return d


def plant_scene(scene: Scene, origin: str = "plant") -> Scene:
    """The scene the plant runs: the model's scene with its disturbance applied (pushes
    need the impulse map of the general model, or of the rough one on a rough plane: it
    is forced when there are any; a scene that is not one point runs a moments model,
    which has it)."""
    dist = scene.disturbance
    doc = plant_doc(scene.doc, dist)
    if dist is not None and dist.pushes and scene.one_point:
        doc.setdefault("run", {})["model"] = "rough" if scene.friction > 0 else "general"
    try:
        return parse_scene(doc, origin)
    except SceneError as exc:
        raise SceneError("[disturbance]", f"gives a plant that is not a valid scene: "
                                          f"{exc}") from None


# a loop's samples over its run, at most: each is a step of the runtime and a row (a
# period of 1e-15 s had run 167 calls below the loop's least step into a penetration with
# a reaction of 4e27 N; one of 1e-6 s over 5 s, 5e6 steps and rows, for minutes)
MAX_SAMPLES = 1e6


def check_samples(period: float, duration: float) -> None:
    """Refuse a sample period that asks more than MAX_SAMPLES samples of the run."""
    if period > 0.0 and duration / period > MAX_SAMPLES:
        raise SceneError("[control].period", f"gives {duration / period:.3g} samples over "
                                             f"the run's {duration:g} s (at most "
                                             f"{MAX_SAMPLES:.0e}: each is a step and a row)")


def loop(controller, scene: Scene, period: float = 0.0, channels: tuple = ()) -> Loop:
    """The loop around a run of ``scene``'s plant: ``controller``, the sample period, and
    the disturbance's noise, seed and pushes (``channels``: on a law of several bodies,
    the outputs the controller drives, :class:`~derive.runtime.loop.Loop`)."""
    dist = scene.disturbance or Disturbance()
    return Loop(controller, period=period, noise=dist.noise, seed=dist.seed,
                pushes=np.array(dist.pushes, dtype=float).reshape(-1, 7),
                channels=tuple(channels))

"""Which ``[stability]`` keys ``derive stability`` reads in a scene: the motion it
analyses (free flight, or periodic bouncing on the plane) and the refusal of a key that
motion does not read (the table is the schema's STABILITY_KEYS).  Here, not in
:mod:`derive.stability`, so that ``derive scene check`` says it without loading the
analysis."""
from __future__ import annotations

from .errors import SceneError
from .schema import STABILITY_KEYS, STABILITY_PERTURBATIONS_RULE


def motion(scene) -> str:
    """What ``derive stability`` analyses in ``scene``: a key of STABILITY_KEYS."""
    return "periodic bouncing" if scene.contact_possible else "free flight"


def refuse_unread(scene) -> None:
    """Every [stability] key given acts or is refused: a key the scene's motion does not
    read (STABILITY_KEYS says which and why), and perturbations where no perturbed run is
    asked (long_periods 0)."""
    kind = motion(scene)
    for key, why in STABILITY_KEYS[kind].items():
        if why is not None and f"[stability].{key}" in scene.given:
            reads = ", ".join(k for k, w in STABILITY_KEYS[kind].items() if w is None)
            raise SceneError(f"[stability].{key}", f"{kind} does not read it ({why}); "
                                                   f"it reads {reads}")
    if "[stability].perturbations" in scene.given and not scene.stability.long_periods:
        raise SceneError("[stability].perturbations", STABILITY_PERTURBATIONS_RULE)

"""A scene run as its tables ask: the one entry of ``derive.simulate`` and ``derive
simulate``.

* ``[control]``: the loop closed around the plant (:mod:`derive.control.closed`);
* ``[disturbance]`` alone: an open run of the scene with its pushes applied (a push is the
  plant's, not the controller's: it acts whether or not a loop is closed), in the general
  (on a rough plane the rough) model, whose impulse map the pushes need; what only a
  controller reads or keeps apart, the noise and the plant's factors, is refused when the
  scene is read (:data:`derive.scene.parse.CONTROLLER_ONLY`);
* neither: the plain run (:func:`derive.runtime.driver.simulate`).

A ``[disturbance]`` had been accepted without ``[control]`` and then ignored: a 0.5 N s
push on the rolling robot ran as if it were not there (a new user's trial, issue 34).
"""
from __future__ import annotations

import time

from ..progress import count
from ..runtime.driver import Result, prepare, run_prepared, simulate
from ..scene import Scene, load_scene
from . import plant


def run_scene(scene, progress: bool = False) -> Result:
    """The run of a scene (a path, a dict or a Scene) as its tables ask (the module's
    docstring).  A closed loop's Result carries its :class:`~derive.control.closed.
    ClosedLoop` as ``result.loop``."""
    sc = load_scene(scene)
    if sc.control is not None:
        from .closed import simulate_closed
        closed = simulate_closed(sc)
        closed.result.loop = closed
        return closed.result
    if sc.disturbance is not None:
        return simulate_pushed(sc, progress)
    return simulate(sc, progress=progress)


def simulate_pushed(sc: Scene, progress: bool = False) -> Result:
    """An open run of ``sc`` with its ``[disturbance]``'s pushes (see the module)."""
    start = time.perf_counter()
    pl = plant.plant_scene(sc)                 # the general model when there are pushes
    loop = plant.loop(_open, sc, 0.0)
    prep = prepare(pl)
    t_prepare = time.perf_counter() - start
    bar = None
    if progress:
        from ..progress import Bar
        bar = Bar("simulating")
    try:
        res = run_prepared(prep, progress=bar.update if bar else None, loop=loop)
    finally:
        if bar:
            bar.close()
    res.timings = {"prepare_s": t_prepare, **res.timings,
                   "library_build_s": prep.library.build_seconds}
    n = len(sc.disturbance.pushes)
    if n:
        res.why = (f"[disturbance]'s {count(n, 'push', 'pushes')} need{'s' if n == 1 else ''} the "
                   f"{res.model} model's impulse map (an open run: no [control])")
    return res


def _open(call) -> None:
    """The open loop's controller: the scene's own law goes on."""
    return None

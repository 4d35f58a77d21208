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

import copy
import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

from ..progress import count
from ..runtime.driver import Result, prepare, run_prepared, simulate
from ..scene import Scene, load_scene
from . import plant


def run_scene(scene, progress: bool = False) -> Result:
    """The run of a scene (a path, a dict or a Scene) as its tables ask (the module's
    docstring).  A closed loop's Result carries its :class:`~derive.control.closed.
    ClosedLoop` as ``result.loop``."""
    sc = load_scene(scene)
    if (sc.control is not None or sc.disturbance is not None) and sc.on_plane:
        from ..runtime import choice        # a body on its face: the base model's refusal
        if choice.base_refusal(sc) is None:  # of [control] and [disturbance], by name
            choice.choose(sc)
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
    # the general model when there are pushes; the rows sc asks for (a re-run for the
    # pictures sets output_dt on the Scene, which the plant's document does not hold)
    pl = replace(plant.plant_scene(sc), output_dt=sc.output_dt)
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
    res.rerun = lambda output_dt: simulate_pushed(replace(sc, output_dt=output_dt))
    n = len(sc.disturbance.pushes)
    if n:
        res.why = (f"[disturbance]'s {count(n, 'push', 'pushes')} need{'s' if n == 1 else ''} the "
                   f"{res.model} model's impulse map (an open run: no [control])")
    return res


def _open(call) -> None:
    """The open loop's controller: the scene's own law goes on."""
    return None


def run_many(scene, variants, workers: int | None = None, scheduler: str | None = None,
             keep: str = "summary", progress: bool = False, strict: bool = True, **kwargs):
    """A parameter study as its scene's tables ask: :func:`derive.runtime.batch.
    simulate_many` for a plain scene; a scene with ``[control]`` or ``[disturbance]`` runs
    each variant as :func:`run_scene` does (the loop closed, the pushes applied), one at a
    time in this process's threads (a study had run such variants open and unpushed)."""
    from ..runtime import batch, study
    from ..scene import SceneError, overrides
    doc = _doc_of(scene)
    if "control" not in doc and "disturbance" not in doc:
        return batch.simulate_many(scene, variants, workers=workers, scheduler=scheduler,
                                   keep=keep, progress=progress, strict=strict, **kwargs)
    tables = " and ".join(f"[{t}]" for t in ("control", "disturbance") if t in doc)
    if scheduler is not None or kwargs.get("executor", "threads") != "threads":
        raise batch.BatchError("scheduler" if scheduler else "executor",
                               f"a study of a scene with {tables} runs each variant's loop in "
                               "this process's threads")
    if keep not in ("summary", "result"):
        raise batch.BatchError("keep", f"must be 'summary' or 'result' (got {keep!r})")
    items = batch.expand(variants)
    start = time.perf_counter()

    def one(k: int):
        try:
            d = copy.deepcopy(doc)
            for name, value in items[k].items():
                overrides.apply_to_doc(d, name, copy.deepcopy(value))
            res = run_scene(d)
            return study.summary_row(res), res
        except (SceneError, overrides.OverrideError) as exc:
            return {"error": f"variant {k + 1}: {exc}"}, None
    n_workers = 1 if workers is None and len(items) <= 8 else (workers or os.cpu_count() or 1)
    bar = None
    if progress:
        from ..progress import Bar
        bar = Bar("variants")
    out = []
    with ThreadPoolExecutor(max_workers=n_workers) as pool:
        for k, got in enumerate(pool.map(one, range(len(items)))):
            out.append(got)
            if bar:
                bar.update((k + 1) / len(items))
    if bar:
        bar.close()
    rows = [row for row, _ in out]
    if strict:
        bad = next((r["error"] for r in rows if "error" in r), None)
        if bad is not None:
            raise batch.BatchError("variants", bad)
    return batch.Batch(items, study.columns_of_rows(rows),
                       results=[res for _, res in out] if keep == "result" else [],
                       seconds=time.perf_counter() - start, executor="threads",
                       workers=n_workers, tasks=len(items))


def _doc_of(scene) -> dict:
    """A scene's dict (a path, a dict or a Scene)."""
    if isinstance(scene, dict):
        return scene
    return load_scene(scene).doc

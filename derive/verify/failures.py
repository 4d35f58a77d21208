"""``derive verify failures``: hard scenes through every method, and what came out.

Scenes (each against a reference computed another way, :func:`derive.verify.oracle.
reference_run`):

* impacts accumulating to resting contact (e = 0.5, e = 0.1) and a plastic ball lifted
  off by its point (e = 0): :func:`derive.reference.translational_bounce`, flights in
  closed form, only 1-D root finding numerical;
* a grazing impact (a floating carrier, g = 0, whose point's oscillation brings S to the
  plane with v_n close to 0) and chatter on a fast-vibrating point (impacts 1e-9 s apart,
  several inside one step, then rest and lift-off): the same reference;
* a nearly singular J (a thin rod, J_x << J_y = J_z, with a heavy point close to its
  axis) and a fast spin (omega large against the point's frequency): the runtime at
  1e-13 checked against SciPy's DOP853 at 1e-13.

Outcomes (:func:`derive.verify.judges.classify`): ``correct`` (max state error on the
grid <= 1e-6 and no event missed), ``wrong`` (with the error), ``missed events``,
``fell through the plane`` (S below the plane by more than 1e-6 on the grid), or a named
status: ``step_underflow``, ``max_steps``, ``max_events``, ``nonfinite`` from the
runtime, ``stopped at a limit`` (evaluation, impact or time budget) or ``failed`` from a
peer.  The goal: the runtime's error-controlled methods correct on every scene.  Its
fixed-step RK4 and the peers are reported, not judged: a fixed step's accuracy is its
user's choice, and the peers' failures are what the table is for.
"""
from __future__ import annotations

import copy
import time
import tomllib
from dataclasses import dataclass

import numpy as np

from ..bench.routes import Casadi, Run, Runtime, Scipy, StopRun
from ..commands import Target
from ..scene import DEFAULT_SCENE
from .judges import classify
from .oracle import reference_run

TIME_LIMIT = 2.0         # seconds a peer may spend on one scene before it is stopped
JUDGED = ("runtime default (LIE)", "runtime DOPRI5", "runtime DOP853",
          "runtime DOP853+orth")


def _ball(e, law, z0=1.5, g=9.81, duration=3.0, vz=0.0) -> dict:
    doc = tomllib.loads(DEFAULT_SCENE)
    doc["point"]["law"] = list(law)
    doc["initial"].update(omega=[0.0, 0.0, 0.0], com=[0.0, 0.0, z0],
                          com_velocity=[0.3, 0.0, vz])
    doc["plane"]["restitution"] = e
    doc["run"].update(duration=duration, g=g)
    return doc


def _free(**updates) -> dict:
    doc = tomllib.loads(DEFAULT_SCENE)
    doc.pop("plane")
    for section, values in updates.items():
        doc[section].update(values)
    return doc


NU = 0.2 / 1.2          # m/(m+M) of the default bodies


def scenes() -> dict:
    """name -> (scene dict, kind of reference)."""
    return {
        "impacts accumulate, e = 0.5": (_ball(0.5, ["0", "0", "0"]), "translational"),
        "impacts accumulate, e = 0.1": (_ball(0.1, ["0", "0", "0"]), "translational"),
        "lift-off by the point, e = 0": (_ball(0.0, ["0", "0", "0.3*sin(20*t)"], z0=0.51,
                                               duration=1.0), "translational"),
        "grazing impact": (_ball(0.9, ["0", "0", "0.2*sin(5*t)"], z0=0.5 + 0.2 * NU - 1e-7,
                                 g=0.0, duration=1.0), "translational"),
        "impacts inside one step (chatter)": (_ball(0.3, ["0", "0", "0.2*sin(40*t)"],
                                                    z0=0.5 + 0.2 * NU + 0.01, duration=1.0),
                                              "translational"),
        "thin rod, heavy point near its axis": (_free(
            body={"mass": 1.0, "inertia": [1e-5, 0.1, 0.1]},
            point={"mass": 1.0, "law": ["0.3*sin(2*t)", "0.002", "0.002*cos(t)"]},
            initial={"omega": [2.0, 0.5, 0.3]}, run={"duration": 2.0}), "numerical"),
        "fast spin": (_free(initial={"omega": [0.5, 0.1, 300.0]},
                            run={"duration": 1.0}), "numerical"),
    }


def methods():
    """(label, factory(doc)) at each method's default setting, tolerance 1e-10."""
    return [
        ("runtime default (LIE)", lambda d: Runtime(d, "lie", 1e-10)),
        ("runtime DOPRI5", lambda d: Runtime(d, "dopri5", 1e-10)),
        ("runtime DOP853", lambda d: Runtime(d, "dop853", 1e-10)),
        ("runtime DOP853+orth", lambda d: Runtime(d, "dop853+orth", 1e-10)),
        ("runtime RK4 (T/2000)",
         lambda d: Runtime(d, "rk4", d["run"].get("duration", 5.0) / 2000)),
        ("scipy DOP853", lambda d: Scipy(d, "DOP853", 1e-10, max_impacts=2000)),
        ("scipy RK45", lambda d: Scipy(d, "RK45", 1e-10, max_impacts=2000)),
        ("scipy Radau", lambda d: Scipy(d, "Radau", 1e-8, max_impacts=2000)),
        ("casadi cvodes", lambda d: Casadi(d, 1e-10, budget=50_000)),
    ]


@dataclass
class Outcome:
    """One method on one scene (``outcome`` from :func:`classify`)."""
    scene: str
    method: str
    outcome: str
    error: float
    impacts: int
    reference_impacts: int
    seconds: float


class _Timeout:
    """Stops a peer after TIME_LIMIT seconds of its own evaluations."""

    def __init__(self, route):
        self.route, self.start = route, None
        for name in ("f", "_flow"):               # SciPy's RHS, CasADi's segments
            inner = getattr(route, name, None)
            if inner is not None:
                setattr(route, name, self._capped(inner))

    def _capped(self, inner):
        def call(*args):
            if time.perf_counter() - self.start > TIME_LIMIT:
                raise StopRun(f"time limit ({TIME_LIMIT:g} s)")
            return inner(*args)
        return call

    def result(self):
        self.start = time.perf_counter()
        return self.route.result()


def run(progress=lambda m: None, only: list[str] | None = None,
        method_filter: list[str] | None = None) -> list[Outcome]:
    """Every scene (or those named in ``only``) through every method (or those in
    ``method_filter``), each peer stopped after ``TIME_LIMIT`` seconds."""
    out = []
    for name, (doc, kind) in scenes().items():
        if only and name not in only:
            continue
        progress(f"{name}: reference")
        ref = reference_run(doc, kind)
        plane = "plane" in doc
        for label, make in methods():
            if method_filter and label not in method_filter:
                continue
            progress(f"{name}: {label}")
            start = time.perf_counter()
            try:
                result = _Timeout(make(copy.deepcopy(doc))).result()
            except Exception as exc:                # a peer's own failure is an outcome
                result = Run(np.empty((0, 18)), np.array([]), 0,
                             f"failed: {str(exc).splitlines()[0][:60]}")
            seconds = time.perf_counter() - start
            outcome, err = classify(result, ref, plane)
            out.append(Outcome(name, label, outcome, err, len(result.impacts),
                               len(ref.impacts), seconds))
    return out


def report(outcomes: list[Outcome]) -> str:
    scenes_ = list(dict.fromkeys(o.scene for o in outcomes))
    methods_ = list(dict.fromkeys(o.method for o in outcomes))
    width = max(len(m) for m in methods_) + 2
    lines = []
    for sc in scenes_:
        lines.append(sc)
        for m in methods_:
            o = next((x for x in outcomes if x.scene == sc and x.method == m), None)
            if o is None:
                continue
            err = f"err {o.error:.1e}" if np.isfinite(o.error) else ""
            imp = (f"impacts {o.impacts}/{o.reference_impacts}"
                   if o.reference_impacts or o.impacts else "")
            lines.append(f"  {m:<{width}}{o.outcome:<28}{err:<14}{imp:<18}{o.seconds:8.2f} s")
    lines += [f"goal: {t}" for t in targets(outcomes)]
    return "\n".join(lines)


def targets(outcomes: list[Outcome]) -> list[Target]:
    """The runtime's error-controlled methods (``JUDGED``) correct on every scene."""
    judged = [o for o in outcomes if o.method in JUDGED]
    wrong = [f"{o.method} on {o.scene}: {o.outcome}" for o in judged if o.outcome != "correct"]
    what = (f"the runtime's error-controlled methods correct on every scene "
            f"({len(judged) - len(wrong)} of {len(judged)}")
    what += "; " + "; ".join(wrong[:5]) + ")" if wrong else ")"
    return [Target(what, not wrong)]


def passed(outcomes: list[Outcome]) -> bool:
    return all(t.ok for t in targets(outcomes))

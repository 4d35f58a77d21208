"""A scene run in closed loop: ``[control]`` with mode hop or mirror on a hop of the
paper's reference [5] (derive simulate runs a scene that has a ``[control]`` table
through here).  The plant is the scene with its ``[disturbance]``; the controller keeps
the scene's numbers.  Re-planning (mode replan) plans a task's law: ``derive control``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .. import json_text, layout
from ..runtime.driver import Result, prepare, run_prepared
from ..runtime.loop import realised_law
from ..scene import Scene, SceneError, load_scene
from . import hop, plant


@dataclass
class ClosedLoop:
    """A closed-loop run: its Result, the controller and its design, the realised law."""
    result: Result
    mode: str
    controller: object
    design: hop.Design | None
    law_rows: np.ndarray = field(repr=False)
    target: dict = field(default_factory=dict)

    @property
    def law(self):
        return realised_law(self.law_rows)

    def files(self, plot: bool = True) -> dict:
        """law.csv (the realised law: t and u on its knots and a fine grid), control.json
        and (``plot``) control.png, written with the run's own outputs."""
        law = self.law
        t = np.unique(np.r_[law.knots, np.linspace(law.t_first, law.t_last, 2001)])
        u = layout.u_of_jets(law.jets(t))
        cols = ("t", *layout.U_LABELS)
        rows = "\n".join(",".join(repr(float(v)) for v in (tt, *u[:, k]))
                         for k, tt in enumerate(t))
        out = {"law.csv": ",".join(cols) + "\n" + rows + "\n",
               "control.json": json_text.dumps(self.summary())}
        if plot:
            from .plots import chart
            out["control.png"] = lambda path: chart(self, path)
        return out

    def describe(self) -> str:
        s = f"{self.mode}; {int(self.result.stats.get('controller_calls', 0))} calls"
        if self.design is not None:
            rho = max(abs(self.design.open_loop))
            lam = max(abs(self.design.closed_loop))
            s += (f"; hop multipliers |rho| up to {rho:.4g} open loop, |lambda| up to "
                  f"{lam:.4g} closed")
        if "apex_height" in self.target:
            s += f"; apex target {self.target['apex_height']:.4g} m"
        return s + f"; designed in {self.result.timings.get('design_s', 0.0):.2f} s"

    def summary(self) -> dict:
        """What control.json holds."""
        out = {"mode": self.mode, "target": self.target, "status": self.result.status,
               "controller_calls": int(self.result.stats.get("controller_calls", 0)),
               "law_changes": int(self.result.stats.get("law_changes", 0)),
               "impacts": int(self.result.stats.get("impacts", 0))}
        d = self.design
        if d is not None:
            out["design"] = {
                "gain": d.gain, "K": d.K.ravel().tolist(), "A": d.A.tolist(),
                "B": d.B.ravel().tolist(),
                "open_loop_multipliers": _complex(d.open_loop),
                "closed_loop_eigenvalues": _complex(d.closed_loop),
                "orbit": {"t_impact": d.orbit.t, "v": d.orbit.v, "a": d.orbit.gait.a,
                          "W": d.orbit.gait.W}}
            hist = getattr(self.controller, "history", [])
            out["per_hop"] = [{"t": float(t), "deviation": s.tolist(), "delta_a": float(da)}
                              for t, s, da in hist]
        return out


def _complex(z) -> list:
    return [[float(np.real(v)), float(np.imag(v))] for v in z]


def simulate_closed(scene, progress=None) -> ClosedLoop:
    """Run a scene with a ``[control]`` table in closed loop (see the module's docstring)."""
    start = time.perf_counter()
    sc: Scene = load_scene(scene)
    ctl = sc.control
    if ctl is None:
        raise SceneError("[control]", "is required to close the loop")
    if ctl.mode == "replan":
        raise SceneError("[control].mode", "replan re-plans a task's law: give a task "
                                           "([plan] and [control]) to derive control")
    pl = plant.plant_scene(sc)
    pushes = bool(sc.disturbance and sc.disturbance.pushes)
    model = "general" if pushes or "pose" in sc.outputs else "vertical"
    pl = replace(pl, model=model)
    L = layout.of(model)
    hm = hop.HopMap(sc)                       # the model's numbers, not the plant's
    target, design = {}, None
    if ctl.mode == "hop":
        if ctl.apex_height is not None:
            gait, orbit = hop.gait_for_apex(hm, ctl.apex_height)
        else:
            gait, orbit = hm.gait, None
        design = hop.design(hm, gait, ctl.gain, ctl.state_weight, ctl.input_weight, orbit)
        controller = hop.HopController(design, L)
        # a sample every gait period: where no impact comes (resting contact, a long
        # flight) the controller goes on with the gait before its law ends
        period = ctl.period or design.orbit.gait.period
        target = {"apex_height": hop.orbit_apex(hm, design.orbit), "W": gait.W, "a": gait.a}
    else:
        apex = ctl.apex_height if ctl.apex_height is not None else \
            hop.orbit_apex(hm, hop.find_orbit(hm, hm.gait))
        period = ctl.period or 0.002
        controller = hop.MirrorLaw(sc, apex=apex, period=period, layout_=L)
        target = {"apex_height": apex}
    if ctl.duration is not None:
        pl = replace(pl, duration=ctl.duration)
    plant.check_samples(period, pl.duration)
    loop = plant.loop(controller, sc, period)
    t_design = time.perf_counter() - start
    start = time.perf_counter()
    prep = prepare(pl)
    t_prepare = time.perf_counter() - start
    res = run_prepared(prep, loop=loop, progress=progress)
    res.timings = {"design_s": t_design, "prepare_s": t_prepare, **res.timings,
                   "library_build_s": prep.library.build_seconds}
    # the outputs (P, the energy balance) read the law the loop ran, not the scene's
    res.scene = replace(res.scene, law=realised_law(loop.law_rows(), "the closed loop's "
                                                    "realised law"), law_text=())
    res.why = ("the closed loop's pushes need the general model" if pushes else
               "the pose is asked" if model == "general" else
               "the closed loop runs the vertical model (P on the axis, no pushes)")
    return ClosedLoop(res, ctl.mode, controller, design, loop.law_rows(), target)

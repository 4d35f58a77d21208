"""A base run that lifts off goes on in the general model (issue 33, "honest ends").

At lift-off N falls to 0 continuously and the face leaves the plane flat, v_n = 0: the
general model is exact there.  The base model's state (X_O, Y_O, psi and their rates)
gives the general state of the same body, points and rotors at that instant
(:func:`general_state`: ``A = R_z(psi) Q_face``, ``r_C = r_O + A OC(t)``, ``V_C = V_O +
A (omega x OC + OC')``, ``omega = psi' e_z``, the laws at the same time), and the scene
goes on from there in the model the general choice gives it (``rough`` for one point,
``moments_rough`` else) to the end time: one run, one trajectory, one timeline.

The hand-over is the driver's, not the C's: each model is its own library, compiled once
per machine, and one who embeds the base model's C gets ``lift_off`` with the state at
the located time, from which these formulas give the 18 numbers the general model's
library starts from (derive/docs/bodies.md).  It needs ``[plane].restitution`` (the
flight may land on a corner); without it the run stops at lift-off as before.

Landing flat is a multi-point impact (every corner of the face at once) that the general
model does not make: where a touch of the flight coming down (v_n < 0) finds the touching
face's corners (a disc's rim) within the runtime's height resolution of each other, the
C stops the run there with status ``flat_landing`` (crt_collide, for every flight of a
box or a cylinder, not only this one; :func:`fly` reads the landing from that stop).  A
landing on one corner, an edge's middle or a rim point goes on in the general model.

The flight is the run a scene written from the hand-over's state makes: its law proved
over the flight alone (:func:`flight_scene`), its ``output_dt`` rows on the whole run's
grid (``run_flight``'s origin).  A study's variants hand over too
(:func:`derive.runtime.study.hand_over`, with these functions).
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import abi, face as faces, layout
from . import choice

G = layout.GENERAL
_BEFORE, _AFTER = abi.ROW_KIND["before_event"], abi.ROW_KIND["after_event"]
_MODE_COL = abi.EVENT_COLUMNS.index("mode")
# the face's mode after each base event, written in the events' mode column (the general
# model's timeline reads it)
_BASE_MODES = {"slip": abi.MODE["sliding"], "reversal": abi.MODE["sliding"],
               "stick": abi.MODE["sticking"], "lift_off": abi.MODE["flight"]}


def general_state(scene, st: choice.Start, t: float, q) -> np.ndarray:
    """The 18 numbers of the general state from one state of the base model at time t."""
    return choice.to_general(scene, "base", st, np.array([float(t)]),
                             np.asarray(q, dtype=float)[None], None)[0]


def flight_scene(scene, t: float, state) -> "object":
    """The scene from time t on, started in the general state ``state`` off the face
    (the base model's own keys dropped: the general model refuses them), its law proved
    over the flight alone, as a scene written from that state by hand proves it (the
    summary's time scale bounds the step: the whole run's gave other steps, whose
    impacts' accumulation ended 1e-9 apart)."""
    from ..scene.bodies import summary_over
    state = np.asarray(state, dtype=float)
    duration = scene.t0 + scene.duration - float(t)
    return dataclasses.replace(
        scene, on_plane=False, t0=float(t), duration=duration,
        law_summary=summary_over(scene, float(t), float(t) + duration),
        com=tuple(state[G.com]), com_velocity=tuple(state[G.com_velocity]),
        omega=tuple(state[G.omega]), A0=state[G.A].reshape(3, 3).copy(),
        static_friction=None, pressure=None, model="auto")


def noise(run, i: int) -> tuple[float, float]:
    """(the height resolution, the speed noise) of the runtime at row i of ``run`` (a
    Result of a model with the plane): the heights it does not resolve (the integrator's
    own error in Z_C, or round-off) and the normal speeds it calls round-off (S touching,
    not hitting), read from its own C (crt_eval_noise: crt_plane.h's
    crt_height_resolution and crt_speed_noise), not written again here."""
    return run.session.noise(float(run.t[i]), run.model_q[i])


def flat_spread(scene, A) -> float:
    """How far apart in height the corners (a disc: the rim) of the face nearest to the
    plane are, under attitude A: 2 (a |u_1| + b |u_2|) for a rectangle, 2 R |u_12| for
    a disc, u the vertical in the face's frame (derive/face.py's); inf where no face is
    down (the vertical more than 45 degrees from every face normal).  The runtime's rule
    is its own C (model_face_spread_n, in the body's axes): this is the other way of
    computing it that the robustness judge and the tests check the C's stops against."""
    n = np.asarray(A, dtype=float).reshape(3, 3)[2]
    k = int(np.argmax(np.abs(n)))
    if scene.shape == "cylinder" and k != 2:
        return math.inf
    axis = np.zeros(3)
    axis[k] = math.copysign(1.0, n[k])
    face = faces.face_on(scene.shape, scene.size, scene.center, axis)
    u = face.frame @ n
    if face.kind == "rectangle":
        a, b = face.half
        return 2.0 * (a * abs(u[0]) + b * abs(u[1]))
    return 2.0 * face.half[0] * math.hypot(u[0], u[1])


def hand_over(base, run_flight) -> object:
    """The run of ``base`` (a base Result that stopped with ``lift_off``) continued in
    the general model to the end time: a Result of the flight's model whose rows, events
    and counters are the base run's (in the general layout) then the flight's, with
    ``handover`` saying where and what.  ``run_flight(scene, origin=None) -> Result`` runs
    a scene in its model, with no hand-over, its output_dt rows on the grid origin + k
    output_dt (driver.run_prepared of driver.prepare): the flight's on the run's grid,
    t0 + k output_dt, not counted from the lift-off."""
    scene = base.scene
    t_l = float(base.t[-1])
    if not flies(scene, t_l):
        return base                          # lifted off at the end time: no flight
    state = general_state(scene, base.start, t_l, base.model_q[-1])
    fscene = flight_scene(scene, t_l, state)
    flight, landing = fly(fscene, run_flight, scene.t0)
    # each part's denser rows (the balance's, the pictures') from its own runs: the base
    # alone (simulate of the scene would hand over again), the flight as it was made
    base.rerun = lambda output_dt: run_flight(dataclasses.replace(scene, output_dt=output_dt))
    flight.rerun = lambda output_dt: fly(dataclasses.replace(fscene, output_dt=output_dt),
                                         run_flight, scene.t0)[0]
    return _stitch(base, flight, state, landing)


def flies(scene, t_l: float) -> bool:
    """A lift-off at t_l leaves a flight: not at the end time (to 1e-12 of it)."""
    return scene.t0 + scene.duration - t_l > 1e-12 * max(1.0, abs(t_l))


def at_once(t: float) -> float:
    """The last time that is the hand-over's instant t itself (events there are the
    C's touch of a face just leaving the plane, to 1e-12)."""
    return t + 1e-12 * max(1.0, abs(t))


def fly(fscene, run_flight, origin: float | None = None) -> tuple:
    """The flight from the hand-over (a Result) and its flat landing (None: none).  The
    C stops a flight at a touch coming down (v_n below minus the speed noise) with the
    face flat, status flat_landing (crt_collide: model_face_spread within
    crt_height_resolution), as it stops every other flight of a box or a cylinder; the
    landing's t, spread (the event's value), height resolution (the runtime's own, at the
    touch's row) and v_n are read from that stop.  Touches at the hand-over's instant are
    none: the face is on the plane there with v_n round-off, which the C calls a graze or
    a contact it leaves at once, not a touch coming down.  ``origin``: the output_dt
    grid's (the whole run's t0)."""
    run = run_flight(fscene, origin)
    if run.status != "flat_landing":
        return run, None
    ev = run.events[-1]
    i = len(run.t) - 1
    return run, {"t": float(run.t[i]), "spread": float(ev["value"]),
                 "resolution": noise(run, i)[0], "v_n": float(ev["v_minus"])}


def _stitch(base, flight, state, landing):
    """One Result: the base rows in the general layout, then the flight's (its first row,
    the hand-over's state, the lift-off's after row)."""
    general = base.general
    ev = base.event_rows.copy()
    kinds = abi.names(abi.EVENT_KINDS)
    for r in ev:
        r[_MODE_COL] = _BASE_MODES.get(kinds[int(r[1])], r[_MODE_COL])
    row_kind = flight.row_kind.copy()
    row_kind[0] = _AFTER
    stats = {k: base.stats.get(k, 0.0) + flight.stats.get(k, 0.0) for k in flight.stats}
    out = dataclasses.replace(
        flight, t=np.concatenate([base.t, flight.t]),
        model_q=np.vstack([general, flight.model_q]),
        row_kind=np.concatenate([base.row_kind, row_kind]),
        event_rows=np.vstack([ev, flight.event_rows]) if len(flight.event_rows) else ev,
        stats=stats, scene=base.scene,
        timings={k: base.timings.get(k, 0.0) + flight.timings.get(k, 0.0)
                 for k in set(base.timings) | set(flight.timings)})
    t_l = float(base.t[-1])
    out.why = (f"base until the lift-off at t = {t_l:.6g} s ({base.why}); then {flight.why}")
    out.handover = Handover(base=base, flight=flight, t=float(base.t[-1]), state=state,
                            landing=landing)
    # the face's mode on the base rows (sliding or sticking: base_report.modes), the
    # flight's after; no slip of S on the base rows (the face slides, not a point)
    from .events import face_modes
    out.__dict__["modes"] = np.concatenate([face_modes(base), flight.modes])
    if flight.slip is not None:
        out.__dict__["slip"] = np.vstack([np.full((len(base.t), 2), math.nan), flight.slip])
    return out


@dataclasses.dataclass
class Handover:
    """Where a base run handed over: its own Result (``base``, status lift_off), the
    flight's (``flight``, from the hand-over's state), the time and the 18 numbers, and
    the flat landing that stopped the flight (t, the corners' spread and the height
    resolution, v_n), if one did."""
    base: object
    flight: object
    t: float
    state: np.ndarray
    landing: dict | None = None

    def summary(self) -> dict:
        return {"t": self.t, "model": self.flight.model, "why": self.flight.why,
                "state": dict(zip(map(layout.plain, choice.GENERAL_LABELS),
                                  self.state.tolist())),
                "flight_status": self.flight.status,
                "flat_landing": self.landing}

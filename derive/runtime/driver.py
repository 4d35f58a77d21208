"""``derive.simulate(scene) -> Result``: validate once, choose a precompiled model, fill
its numbers, run the C runtime, and read the results back lazily.

The data flows once: the scene is parsed and validated (its law compiled into a program,
cached by its text), the model chosen, and what the C needs — options, parameters, the
law's arrays, the initial state — handed to a :class:`~derive.runtime.session.Session` of
the model's library (:mod:`derive.runtime.session`, the calls into C).  Extras (the
general layout, omega, the height of S, K) are computed only when read; the events and
the contact mode of each row are read by :mod:`derive.runtime.events`.  Above this
module, :mod:`derive.runtime.motion` computes the mechanics along a run's rows (and
re-runs a scene through :func:`simulate` where it needs rows closer together).
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from .. import abi, layout
from . import bodies, choice, events as timeline
from .build import Library, library
from .geometry import heights, kinetic_moment
from .session import Session, session_for
from ..scene import Scene, load as _load

METHODS = {name: k for k, name in enumerate(abi.names(abi.METHODS))}


_O = abi.OPT


def options(scene: Scene, kind: str) -> np.ndarray:
    """The option vector of a run (indices from abi.OPTIONS)."""
    opt = [0.0] * len(abi.OPTIONS)
    opt[_O["method"]] = METHODS[scene.method]
    contact = scene.contact_possible
    opt[_O["plane"]] = 1.0 if contact else 0.0
    opt[_O["rtol"]], opt[_O["atol"]] = scene.rtol, scene.atol
    h_max = scene.duration / 4.0
    if contact:
        # the gap depends on the law directly, which the step control does not see:
        # at least about six steps per period of the point's motion
        h_max = min(h_max, scene.law_summary.time_scale)
    opt[_O["hmax"]] = h_max if scene.method != "rk4" else scene.step
    opt[_O["rk4_step"]] = scene.step
    opt[_O["max_steps"]] = scene.max_steps
    opt[_O["max_events"]] = scene.max_events
    opt[_O["output_dt"]] = scene.output_dt
    opt[_O["orthonormal"]] = 1.0 if scene.keep_orthonormal else 0.0
    opt[_O["time_scale"]] = scene.duration
    opt[_O["event_tol"]] = 1e-15
    opt[_O["length_scale"]] = choice.length_scale(scene) if contact else 0.0
    opt[_O["zeno_dt"]] = scene.zeno_dt
    opt[_O["start_on_plane"]] = 1.0 if contact and scene.on_plane else 0.0
    return choice.vector(opt)          # (rows of them for a study's columns)


@dataclass
class Prepared:
    """A scene with everything its run needs (no SymPy, nothing compiled per scene)."""
    scene: Scene
    kind: str
    why: str
    start: choice.Start
    options: np.ndarray
    parameters: np.ndarray

    @property
    def library(self) -> Library:
        return library(self.kind)


def prepare(scene, output_origin: float | None = None) -> Prepared:
    """A scene ready to run; ``output_origin``: its output_dt rows on the grid
    output_origin + k output_dt (a run that goes on from another's state at t0, on that
    run's grid: the flight after a lift-off), else t0 + k output_dt."""
    prep = _prepare(scene)
    if output_origin is not None and prep.scene.output_dt > 0.0:
        opt = prep.options.copy()
        opt[_O["output_phase"]] = grid_phase(output_origin, prep.scene.t0,
                                             prep.scene.output_dt)
        prep = replace(prep, options=opt)
    return prep


def grid_phase(origin: float, t0: float, dt: float) -> float:
    """How far after t0 the first point of the grid origin + k dt later than t0 is (in
    (0, dt]; dt, as 0, where t0 is on the grid)."""
    k = math.floor((t0 - origin) / dt) + 1.0
    phase = origin + k * dt - t0
    return phase if phase > 0.0 else phase + dt


def _prepare(scene) -> Prepared:
    scene, static = _load(scene)
    kind, why = choice.choose(scene)
    st = choice.start(scene, kind)
    if static is None:
        return Prepared(scene, kind, why, st, options(scene, kind),
                        choice.parameters(scene, st.constants))
    # a Scene just made from a static part: what reads only its fields is kept there
    # (options: those fields and the RK4 step; parameters: those fields, when the model
    # adds no constants of the initial state); read-only, shared by the scenes
    memo = static.memo
    key = ("options", scene.step, scene.on_plane)     # (of the initial state, not static)
    opt = memo.get(key)
    if opt is None:
        opt = _frozen(options(scene, kind))
        if len(memo) < 16:                   # (RK4's default step follows omega)
            memo[key] = opt
    prm = memo.get("parameters") if not st.constants else None
    if prm is None:
        prm = _frozen(choice.parameters(scene, st.constants))
        if not st.constants:
            memo["parameters"] = prm
    return Prepared(scene, kind, why, st, opt, prm)


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


@dataclass
class Result:
    """The run of a scene.  ``t``, ``q`` (general layout when the pose is asked, else the
    model's own), ``state_names`` (trajectory.csv's: ``dX_C``), ``row(k)`` (a row by name),
    ``impacts`` (t, I, v_n-, v_n+), ``status``; the rest on demand: ``general``,
    ``omega``, ``height``, ``momentum``, ``extras``."""
    scene: Scene
    model: str
    why: str
    t: np.ndarray
    model_q: np.ndarray
    model_labels: tuple
    row_kind: np.ndarray
    event_rows: np.ndarray
    stats: dict
    summary: dict
    status: str
    start: choice.Start
    rates: np.ndarray | None = field(repr=False, default=None)   # dq/dt rows (planar, axisym.)
    timings: dict = field(default_factory=dict)
    loop: object = field(repr=False, default=None)   # a closed loop's ClosedLoop (control)
    # the same run again with another output_dt (output_dt -> Result), for the pictures'
    # and the energy balance's denser rows; None: driver.simulate of the scene, which is
    # the run unless it had pushes or a closed loop (their producers set it)
    rerun: object = field(repr=False, default=None)
    # a base run that lifted off and went on in the general model (runtime/handover.py)
    handover: object = field(repr=False, default=None)

    @cached_property
    def session(self) -> Session:
        """A session of this run's model set up with its law, numbers and initial state,
        for evaluations after the run (the contact equations of the energy balance).  Its
        own: later runs of the thread's session do not change it."""
        return ready_session(self.scene, self.model, self.start)

    @cached_property
    def omega(self) -> np.ndarray:
        return choice.omega_of(self.scene, self.model, self.start, self.t, self.model_q,
                               self.rates)

    @cached_property
    def general(self) -> np.ndarray | None:
        return choice.to_general(self.scene, self.model, self.start, self.t, self.model_q,
                                 self.omega if self.model in ("planar", "axisymmetric")
                                 else None)

    @property
    def q(self) -> np.ndarray:
        return self.general if "pose" in self.scene.outputs and self.general is not None \
            else self.model_q

    @property
    def state_names(self) -> tuple:
        """The columns of ``q`` as trajectory.csv names them (``dX_C`` is X_C')."""
        labels = choice.GENERAL_LABELS if "pose" in self.scene.outputs and \
            self.general is not None else self.model_labels
        return tuple(layout.plain(n) for n in labels)

    def row(self, k: int = -1) -> layout.StateRow:
        """Row ``k`` of the run by name: ``t`` and the states (``res.row()["dZ_C"]``; the
        derivation's ``Z_C'`` finds it too)."""
        return layout.StateRow(t=float(self.t[k]),
                               **dict(zip(self.state_names, self.q[k].tolist())))

    @cached_property
    def height(self) -> np.ndarray | None:
        if not self.scene.size:
            return None
        zn = choice.vertical_of(self.model, self.general, self.model_q)
        if zn is None:
            return None
        return heights(self.scene, self.t, *zn)

    @cached_property
    def momentum(self) -> dict:
        """K about C in body axes (E1.4), |K|, and K in fixed axes when the attitude is
        known."""
        if self.scene.one_point:
            K = kinetic_moment(self.scene, self.omega, self.scene.law.jets(self.t))
        else:                                   # every body's moments (runtime/bodies.py)
            K = bodies.kinetic_moment(self.scene, bodies.along(self.scene, self.t),
                                      self.omega)
        out = {"K_body": K, "K_norm": np.linalg.norm(K, axis=1)}
        if self.general is not None:
            A = self.general[:, layout.GENERAL.A].reshape(-1, 3, 3)
            out["K_fixed"] = np.einsum("nij,nj->ni", A, K)
        return out

    @property
    def extras(self) -> dict:
        wants = set(self.scene.outputs)
        out = {}
        if "omega" in wants:
            out["omega"] = self.omega
        if "height" in wants and self.height is not None:
            out["height"] = self.height
        if "momentum" in wants:
            out["momentum"] = self.momentum
        return out

    @property
    def rough(self) -> bool:
        """The run has Coulomb friction at S (the rough model, or moments_rough)."""
        return self.model in choice.ROUGH_KINDS

    @cached_property
    def events(self) -> list:
        """One dict per event: t, kind, value, v_minus, v_plus (t_accumulation for a
        contact).  The rough model adds ``mode`` (the contact mode after it: flight,
        sliding, sticking), and for impacts the tangential impulse P_X, P_Y, the slip of S
        before and after, the work of the normal impulse and of friction, and ``stage``
        (what happened inside: slip, stick, reslide); for stick, slip and reversal,
        v_minus and v_plus are the slip speed before and after and value the normal
        reaction (stick, reversal) or |R_t|/(mu_f R_Z) (slip).  See
        :func:`derive.runtime.events.decode`."""
        return timeline.decode(self.event_rows, self.rough, self.couples_on)

    @property
    def couples_on(self) -> bool:
        """The rough model with spin friction or rolling resistance."""
        return self.rough and (self.scene.spin_friction > 0.0
                               or self.scene.rolling_resistance > 0.0)

    @cached_property
    def couples(self) -> np.ndarray:
        """The couples' channels held on every row (bits abi.COUPLE_BITS: 1 the spin, 2 the
        rolling; 0 in flight and without couples), from the events as :attr:`modes`."""
        return timeline.contact_couples(self)

    @cached_property
    def modes(self) -> np.ndarray:
        """The contact mode of every row (indices into abi.MODES: flight, smooth contact,
        sliding, sticking), from the events (events.contact_modes)."""
        return timeline.contact_modes(self)

    @cached_property
    def slip(self) -> np.ndarray | None:
        """The rough model: the slip velocity of S (v_X, v_Y, fixed axes) on every row,
        from the runtime's general_contact_velocity; None for the other models."""
        if not self.rough:
            return None
        _, _, v = self.session.rough_rows(self.t, self.model_q, np.zeros(len(self.t)))
        return v[:, :2]

    IMPACT_FRICTION_COLUMNS = timeline.IMPACT_FRICTION_COLUMNS

    @cached_property
    def impacts_friction(self) -> np.ndarray:
        """The rough model: per impact the columns of ``IMPACT_FRICTION_COLUMNS`` (stage:
        abi.IMPACT_STAGES); (0, 9) otherwise."""
        if not self.rough:
            return np.zeros((0, len(self.IMPACT_FRICTION_COLUMNS)))
        return timeline.impacts_friction(self.event_rows)

    @cached_property
    def impacts(self) -> np.ndarray:
        return timeline.impacts(self.event_rows)

    @property
    def min_height(self) -> float:
        return self.summary["min_height"]

    @property
    def min_normal(self) -> float:
        return self.summary["min_normal"]



def ready_session(scene, kind: str, start: choice.Start) -> Session:
    """A session of model ``kind`` of its own (not the thread's), set up with the scene's
    law, numbers and the initial state ``start``: for evaluations (Session.contact,
    Session.noise, ...) with no run."""
    s = Session(library(kind), chunk=16)
    s.set_law(scene.runtime_law)
    s.init(options(scene, kind), choice.parameters(scene, start.constants), scene.t0,
           start.q0)
    return s


def run_prepared(prep: Prepared, session: Session | None = None, progress=None,
                 loop=None) -> Result:
    """Run a prepared scene (``loop``: closed around the run, see derive.runtime.loop)."""
    timings = {}
    start = time.perf_counter()
    session = session or session_for(prep.kind)
    timings["load_s"] = time.perf_counter() - start
    start = time.perf_counter()
    session.set_law(prep.scene.runtime_law)
    raw = session.run(prep.scene.t0, prep.scene.duration, prep.start.q0, prep.options,
                      prep.parameters, progress, loop=loop)
    rates = session.rhs_rows(raw.t, raw.q) if prep.kind in ("planar", "axisymmetric") \
        else None
    timings["run_s"] = time.perf_counter() - start
    return Result(scene=prep.scene, model=prep.kind, why=prep.why, t=raw.t, model_q=raw.q,
                  model_labels=session.library.labels, row_kind=raw.kinds,
                  event_rows=raw.events, stats=raw.stats, summary=raw.summary,
                  status=raw.status, start=prep.start, rates=rates, timings=timings)


def run_scene(prep: Prepared, session: Session | None = None, progress=None) -> Result:
    """The run of a prepared scene as :func:`simulate` makes it: a base run that lifts off
    with ``[plane].restitution`` goes on in the general model (runtime/handover.py).  A
    study's whole results (simulate_many's keep = "result") are these."""
    result = run_prepared(prep, session, progress)
    if result.status == "lift_off" and prep.scene.restitution_given:
        from .handover import hand_over        # the flight from the lift-off on
        result = hand_over(result, lambda sc, origin=None: run_prepared(prepare(sc, origin)))
        if result.handover is not None:        # (the stitched run with rows every dt)
            scene = prep.scene
            result.rerun = lambda dt: simulate(dataclasses.replace(scene, output_dt=dt))
    return result


def simulate(scene, progress: bool = False) -> Result:
    """Simulate a scene (a path, a dict of the schema, or a :class:`Scene`); see the
    README's recipes and derive/docs/runtime.md.  ``progress``: a bar on stderr for runs
    longer than a second."""
    start = time.perf_counter()
    prep = prepare(scene)
    t_prepare = time.perf_counter() - start
    bar = None
    if progress:
        from ..progress import Bar
        bar = Bar("simulating")
    result = run_scene(prep, progress=bar.update if bar else None)
    if bar:
        bar.close()
    result.timings = {"prepare_s": t_prepare, **result.timings,
                      "library_build_s": prep.library.build_seconds}
    return result

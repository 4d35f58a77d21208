"""``derive.simulate(scene) -> Result``: choose the model, specialise, compile (cached),
integrate with the C runtime, and post-process into the layout the scene asked for."""
from __future__ import annotations

import ctypes
import time
from dataclasses import dataclass, field

import numpy as np

from .. import models as dm
from ..progress import Bar
from .build import compile_scene, render
from .geometry import lowest_point_numeric
from .scene import Scene, law_functions, load_scene
from .scene_models import SceneModel, build

STATUSES = {0: "paused", 1: "done", 2: "max_events", 3: "step_underflow", 4: "nonfinite",
            5: "max_steps", 6: "bad_options"}
METHODS = {"rk4": 0, "dopri5": 1, "dop853": 2}
EVENT_KINDS = {1: "impact", 2: "contact", 3: "liftoff", 4: "graze"}
STAT_NAMES = ("steps", "rejected", "rhs_evaluations", "event_function_evaluations",
              "impacts", "contacts", "liftoffs", "grazes")
ROW_KINDS = {0: "step", 1: "before_event", 2: "after_event"}


@dataclass
class Result:
    t: np.ndarray                 # (N,)
    q: np.ndarray                 # (N, n_states)
    state_names: tuple
    impacts: np.ndarray           # (K, 4): t, I, v_n-, v_n+
    status: str
    model: str
    why: str
    events: list = field(default_factory=list)     # dicts: t, kind, value, v_minus, v_plus
    row_kind: np.ndarray = None   # per row: 0 step, 1 just before an event, 2 just after
    stats: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    ops: dict = field(default_factory=dict)
    extras: dict = field(default_factory=dict)      # omega, height, momentum as asked
    scene: Scene = None
    model_q: np.ndarray = None    # the trajectory in the model's own layout
    model_labels: tuple = ()
    scene_model: SceneModel = None


def gap_margin(scene: Scene) -> float:
    """How far the point's own motion can move S between the ends of a step:
    the nu n.OP term of the gap varies by at most 2 nu max|OP| (sampled finely)."""
    if not scene.contact_possible:
        return 0.0
    ts = np.linspace(scene.t0, scene.t0 + scene.duration, 20001)
    r = law_functions(scene)(ts)[[0, 3, 6]]
    nu = scene.m / (scene.m + scene.M)
    return float(2.0 * nu * np.max(np.linalg.norm(r, axis=0)) * 1.01)


def law_time_scale(scene: Scene) -> float:
    """sqrt(amplitude / max |OP''|): 1/W for a harmonic law of frequency W."""
    ts = np.linspace(scene.t0, scene.t0 + scene.duration, 20001)
    v = law_functions(scene)(ts)
    r, a = v[[0, 3, 6]], v[[2, 5, 8]]
    amp = np.max(np.linalg.norm(r - r.mean(axis=1, keepdims=True), axis=0))
    acc = np.max(np.linalg.norm(a, axis=0))
    return float(np.sqrt(amp / acc)) if acc > 0 and amp > 0 else np.inf


def _options(scene: Scene) -> np.ndarray:
    opt = np.zeros(14)
    opt[0] = METHODS[scene.method]
    opt[1], opt[2] = scene.rtol, scene.atol
    opt[3] = 0.0                                      # initial step: automatic
    h_max = scene.duration / 4.0
    if scene.contact_possible:
        # the gap depends on the law directly, which the step control does not see:
        # at least about six steps per period of the point's motion
        h_max = min(h_max, law_time_scale(scene))
    opt[4] = h_max if scene.method != "rk4" else scene.step
    opt[5] = scene.step
    opt[6] = scene.max_steps
    opt[7] = scene.max_events
    opt[8] = scene.output_dt
    opt[9] = 1.0 if scene.keep_orthonormal else 0.0
    opt[10] = scene.duration                          # time scale
    opt[11] = scene.zeno_dt
    opt[12] = 1e-15                                   # event location, relative to the scale
    opt[13] = gap_margin(scene)
    return opt


def prepare(scene) -> tuple[Scene, SceneModel, object, dict]:
    """Validate, choose and build the model, render and compile its runtime."""
    timings = {}
    start = time.perf_counter()
    scene = load_scene(scene)
    model = build(scene)
    timings["specialise_s"] = time.perf_counter() - start
    start = time.perf_counter()
    rendered = render(model, scene.name)
    timings["render_s"] = time.perf_counter() - start
    start = time.perf_counter()
    library = compile_scene(rendered)
    timings["compile_s"] = time.perf_counter() - start
    ops = {"rhs_specialised": rendered.rhs_ops, "rhs_generic": rendered.generic_ops}
    return scene, model, library, {"timings": timings, "ops": ops, "options": _options(scene)}


class Session:
    """A runtime session with its buffers, reusable for repeated runs of one scene."""

    def __init__(self, library, scene: Scene, model: SceneModel, chunk: int = 8192,
                 options: np.ndarray | None = None):
        self.library, self.scene, self.model = library, scene, model
        nq = library.nq
        self._session = ctypes.create_string_buffer(library.session_size + 64)
        base = ctypes.addressof(self._session)
        self._handle = ctypes.c_void_p((base + 63) // 64 * 64)
        self.options = np.ascontiguousarray(options if options is not None else _options(scene))
        self.q0 = np.ascontiguousarray(model.q0, dtype=float)
        self.chunk = chunk
        self.t_buf = np.zeros(chunk)
        self.q_buf = np.zeros((chunk, nq))
        self.k_buf = np.zeros(chunk, dtype=np.intc)
        self.ev_buf = np.zeros((chunk, 5))
        dp, ip = ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int)
        self._ptrs = (self.options.ctypes.data_as(dp), self.q0.ctypes.data_as(dp),
                      self.t_buf.ctypes.data_as(dp), self.q_buf.ctypes.data_as(dp),
                      self.k_buf.ctypes.data_as(ip), self.ev_buf.ctypes.data_as(dp))
        self._n_out, self._n_ev = ctypes.c_int(0), ctypes.c_int(0)

    def run(self, progress: bool = False, params=None):
        """Integrate once; returns rows (t, q, kind), events, stats, status.
        ``params``: the values of a parametric model's parameters."""
        lib = self.library.lib
        opt_p, q0_p, t_p, q_p, k_p, ev_p = self._ptrs
        scene = self.scene
        if params is not None:
            prm = np.ascontiguousarray(params, dtype=float)
            if prm.size != self.library.n_params:
                raise ValueError(f"{prm.size} parameters for a model with "
                                 f"{self.library.n_params}")
            lib.crt_set_params(self._handle, prm.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
        status = lib.crt_init(self._handle, opt_p, scene.t0, q0_p)
        t_end = scene.t0 + scene.duration
        ts, qs, kinds, evs = [], [], [], []
        bar = Bar("simulating", progress)
        while status == 0:
            status = lib.crt_advance(self._handle, t_end, t_p, q_p, k_p, self.chunk,
                                     ctypes.byref(self._n_out), ev_p, self.chunk,
                                     ctypes.byref(self._n_ev))
            n, ne = self._n_out.value, self._n_ev.value
            ts.append(self.t_buf[:n].copy())
            qs.append(self.q_buf[:n].copy())
            kinds.append(self.k_buf[:n].copy())
            evs.append(self.ev_buf[:ne].copy())
            if progress:
                t_now = lib.crt_time(self._handle)
                bar.update((t_now - scene.t0) / scene.duration, f"t = {t_now:.4g}")
        bar.close()
        stats = (ctypes.c_long * 8)()
        lib.crt_stats(self._handle, stats)
        join = (lambda parts: parts[0]) if len(ts) == 1 else np.concatenate
        return (join(ts), join(qs), join(kinds), join(evs),
                dict(zip(STAT_NAMES, list(stats))), STATUSES.get(status, str(status)))


def run_library(library, scene: Scene, model: SceneModel, progress: bool = True,
                chunk: int = 8192, options: np.ndarray | None = None):
    """Integrate with the compiled runtime; returns raw rows, events, stats, status."""
    return Session(library, scene, model, chunk, options).run(progress)


def simulate(scene, progress: bool = True) -> Result:
    """Simulate a scene (a path, TOML text via a path, a dict of the schema, or a
    :class:`Scene`)."""
    scene, model, library, info = prepare(scene)
    start = time.perf_counter()
    t, Q, kinds, ev, stats, status = run_library(library, scene, model, progress,
                                                 options=info["options"])
    info["timings"]["run_s"] = time.perf_counter() - start
    start = time.perf_counter()
    result = _assemble(scene, model, t, Q, kinds, ev, stats, status)
    info["timings"]["post_s"] = time.perf_counter() - start
    result.timings, result.ops = info["timings"], info["ops"]
    return result


def _assemble(scene, model, t, Q, kinds, ev, stats, status) -> Result:
    events = [{"t": float(r[0]), "kind": EVENT_KINDS.get(int(r[1]), str(int(r[1]))),
               "value": float(r[2]), "v_minus": float(r[3]), "v_plus": float(r[4])}
              for r in ev]
    impacts = np.array([[e["t"], e["value"], e["v_minus"], e["v_plus"]]
                        for e in events if e["kind"] == "impact"]).reshape(-1, 4)
    wants = set(scene.outputs)
    general = model.to_general(t, Q) if model.to_general is not None else None
    if "pose" in wants:
        q, names = general, dm.STATE_LABELS["general"]
    else:
        q, names = Q, model.labels
    extras = {}
    omega = model.omega_of(t, Q) if model.omega_of is not None else None
    if "omega" in wants and omega is not None:
        extras["omega"] = omega
    if "height" in wants or (scene.contact_possible and general is not None):
        h = _height(scene, model, t, Q, general)
        if h is not None and "height" in wants:
            extras["height"] = h
    if "momentum" in wants and omega is not None:
        extras["momentum"] = _momentum(scene, t, omega, general)
    return Result(t=t, q=q, state_names=tuple(names), impacts=impacts, status=status,
                  model=model.kind, why=model.why, events=events, row_kind=kinds,
                  stats=stats, extras=extras, scene=scene, model_q=Q,
                  model_labels=model.labels, scene_model=model)


def _height(scene, model, t, Q, general):
    """Height of the lowest point S above the plane (Z = 0)."""
    if scene.shape == "none":
        return None
    if general is not None:
        Z, N = general[:, 2], general[:, 15:18]
    elif model.kind == "vertical":
        Z, N = Q[:, 0], Q[:, 5:8]
    else:
        return None
    law = law_functions(scene)(t)
    r = law[[0, 3, 6]].T
    nu = scene.m / (scene.m + scene.M)
    s = np.array([lowest_point_numeric(scene, n) for n in N])
    return Z + np.einsum("ij,ij->i", N, s - nu * r)


def _momentum(scene, t, omega, general):
    """K about C in body axes (E1.4 with E1.5), its norm, and in fixed axes when the
    attitude is known."""
    law = law_functions(scene)(t)
    r, v = law[[0, 3, 6]].T, law[[1, 4, 7]].T
    mu = scene.mu
    J = np.asarray(scene.J)
    K = J * omega + mu * (np.einsum("ij,ij->i", r, r)[:, None] * omega
                          - r * np.einsum("ij,ij->i", r, omega)[:, None] + np.cross(r, v))
    out = {"K_body": K, "K_norm": np.linalg.norm(K, axis=1)}
    if general is not None:
        A = general[:, 9:18].reshape(-1, 3, 3)
        out["K_fixed"] = np.einsum("nij,nj->ni", A, K)
    return out

"""The smallest model that answers a scene, its inputs, and its results read back.

Every model is compiled once per machine (:mod:`derive.runtime.build`); here a scene only
chooses one and fills its numbers:

* ``translational`` (Z_C, Z_C'): omega(0) = 0, the law satisfies (2.1) (C2.1, C2.3) and,
  if contact is possible, d = CS x n vanishes at every contact (C2.4);
* ``planar`` (Z_C, Z_C', kappa = K_z, phi): z = 0 in the law, omega(0) along z and, if
  contact is possible, the body z axis horizontal with S in the plane z = 0 (E4.1, E4.2);
* ``axisymmetric`` (psi, phi): free flight, J_x = J_y, x = y = 0 (E3.14);
* ``attitude`` (omega): free flight and only omega or momentum asked;
* ``vertical`` (Z_C, Z_C', omega, n): contact possible, the pose not asked;
* ``general`` (18 states) otherwise;
* ``rough`` (the 18 general states, Coulomb friction at S: crt_rough.h) whenever
  contact is possible and ``[plane].friction > 0``: the slip of S needs the horizontal
  velocity of C and the whole attitude, which the smaller models leave out;
* ``moments`` (``moments_rough`` on a rough plane): the general state with the internal
  bodies seen through their moments, summed in C from every body's law (crt_bodies.h):
  the model of every scene that is not one point (several points, rotors, or none); a
  one-point scene takes it only when ``[run].model`` asks (the same motion as the
  general model's, at about 1.2 times its cost: derive bench bodies).
* ``base`` (X_O, Y_O, psi and their rates: crt_base.h) for a box or a cylinder resting on a
  face on a rough plane (``[initial].on_plane`` with the vertical along a face normal,
  omega(0) along it, O moving horizontally): the face stays on the plane, so its
  horizontal motion and yaw are the whole motion, with friction over the face (Coulomb
  and Contensou) in place of one point's; the run stops with ``tipping`` or (linear
  pressure) ``face_lifting`` where the centre of pressure reaches the face's edge or its
  kern, and with ``lift_off`` where N reaches 0, unless the scene gives
  ``[plane].restitution``: then the driver hands the run over to the general model
  (derive/runtime/handover.py).

The conditions read the law's program (``is_zero``) and its samples; nothing symbolic.
"""
from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from .. import abi, face as faces, layout, shapes
from .geometry import (cross, kinetic_moment, lowest_point_numeric, momentum_frame, rotation_x,
                       rotation_z)
from ..scene import Scene, SceneError
from ..scene.rules import most
from ..scene.schema import SCENE_FIELDS

POSE = "pose"
G = layout.GENERAL
GENERAL_LABELS = G.labels
MOMENTS_KINDS = ("moments", "moments_rough")
ROUGH_KINDS = ("rough", "moments_rough")       # Coulomb friction at S: stick, slip, reversal
# the models whose state is the general one (18 numbers)
GENERAL_STATE = ("general", "rough", *MOMENTS_KINDS)


def _samples(scene: Scene, n: int = 801) -> tuple:
    ts = np.linspace(scene.t0, scene.t0 + scene.duration, n)
    return ts, scene.law.jets(ts)


def symmetry_key(omega, J) -> tuple:
    """What the choice of a model reads of omega(0) and J: (omega = 0, omega along z, J_x =
    J_y to 1e-12 of the largest).  Of one scene, or columns of a study's variants (omega and
    J three entries each, numbers or columns): variants of one scene with the same key
    are answered by the same model."""
    wx, wy, wz = omega
    along_z = (wx == 0.0) & (wy == 0.0)
    return along_z & (wz == 0.0), along_z, abs(J[0] - J[1]) <= 1e-12 * most(J)


def _translational_reason(scene: Scene, still: bool) -> str | None:
    if not still:
        return None
    _, vals = _samples(scene)
    r, a = vals[list(layout.JET_R)], vals[list(layout.JET_A)]
    ra = cross(r.T, a.T)
    scale = max(np.max(np.linalg.norm(r, axis=0)) * np.max(np.linalg.norm(a, axis=0)), 1e-300)
    if np.max(np.abs(ra)) > 1e-12 * scale:
        return None
    why = "omega(0) = 0 and the law satisfies (2.1), OP x A_r = 0 (C2.1, C2.3)"
    if scene.contact_possible:
        n0 = scene.A0[2]
        rn = cross(r.T, n0)
        size = max(max(scene.size), np.max(np.linalg.norm(r, axis=0)), 1e-300)
        s0 = lowest_point_numeric(scene, n0)
        if np.max(np.abs(rn)) > 1e-12 * size or np.max(np.abs(cross(s0, n0))) > 1e-12 * size:
            return None
        why += "; P and S stay on the vertical through O, so d = 0 at impacts (C2.4)"
    return why


def _planar_reason(scene: Scene, along_z: bool) -> str | None:
    if not along_z or not scene.law.is_zero(2):
        return None
    why = "z = 0 in the law and omega(0) along z: omega_x = omega_y = 0 persists (E4.1)"
    if scene.contact_possible:
        if abs(scene.A0[2][2]) > 1e-12 or abs(scene.center[2]) > 1e-12:
            return None
        why += ("; the body z axis is horizontal and S lies in z = 0, so d stays along z "
                "through impacts and contact")
    return why


def _axisymmetric_reason(scene: Scene, still: bool, round_: bool) -> str | None:
    if scene.contact_possible or not round_:
        return None
    if not (scene.law.is_zero(0) and scene.law.is_zero(1)) or still:
        return None
    return "free flight, J_x = J_y and P on the symmetry axis: quadratures (E3.11-E3.14)"


def _moments_why(scene: Scene) -> str:
    from ..scene.bodies import describe
    why = (f"{describe(len(scene.points), len(scene.rotors))}: the carrier sees its "
           "internal bodies through their moments, summed from their laws in C")
    if scene.rough:
        why += f"; the plane has friction (mu_f = {scene.friction:g})"
    return why


BASE_SHAPES = ("box", "cylinder")


# the last scene's (a weak reference to it, {what: value}): a choice and a start read the
# base model's face three or four times and the bodies' offset at t0 twice or three times
_LAST: list = [None]


def _of_scene(scene: Scene, what: str, make):
    """``make()``, kept for the last scene asked about (not made again for it)."""
    last = _LAST[0]
    if last is None or last[0]() is not scene:
        last = (weakref.ref(scene), {})
        _LAST[0] = last
    got = last[1].get(what)
    if got is None:
        got = last[1][what] = make()
    return got


def _base_offset(scene: Scene) -> tuple:
    """OC and OC' at t0 (body axes): where the internal bodies put C, and how fast (read
    only)."""
    def make():
        from . import bodies
        c, cd, _ = bodies.offsets_at(scene, [scene.t0])
        c, cd = c[0], cd[0]
        c.flags.writeable = cd.flags.writeable = False
        return c, cd
    return _of_scene(scene, "offset", make)


def base_face(scene: Scene):
    """The face on the plane (derive/face.py's Face, its frame Q) under the vertical
    A0[2], or ValueError when the vertical is along no face normal."""
    def make():
        face = faces.face_on(scene.shape, scene.size, scene.center, scene.A0[2])
        face.frame.flags.writeable = False
        return face
    return _of_scene(scene, "face", make)


def base_refusal(scene: Scene) -> str | None:
    """Why the base model cannot run ``scene`` (None: it can): a box or a cylinder on a
    face, on a rough plane, turning only about the vertical, O moving horizontally."""
    found = base_refusal_at(scene)
    if found is None:
        return None
    field, rule = found
    return _SUBJECT.get(field, "") + rule


def _initial(scene: Scene) -> dict:
    """The scene's [initial] as given (Scene.given leaves [initial] out)."""
    initial = scene.doc.get("initial")
    return initial if isinstance(initial, dict) else {}


def _attitude_field(scene: Scene) -> str:
    """The field that gave the start's attitude, as the scene wrote it."""
    return "[initial].matrix" if "matrix" in _initial(scene) else "[initial].quaternion"


# how base_refusal's sentences name the field base_refusal_at's rule is about
_SUBJECT = {"[initial].matrix": "[initial]'s attitude ",
            "[initial].quaternion": "[initial]'s attitude ", "[initial].omega": "[initial].omega "}


def base_refusal_at(scene: Scene) -> tuple[str, str] | None:
    """:func:`base_refusal`'s reason as (the field it is about, the rule it breaks)."""
    if scene.shape not in BASE_SHAPES:
        return "[body].shape", (
            f"it needs a box or a cylinder (a flat face to rest on), not "
            f"{shapes.with_article(scene.shape) if scene.shape != 'none' else 'no shape'}")
    if not scene.contact_possible or not scene.on_plane:
        return "[initial].on_plane", ("it needs [plane] and [initial].on_plane = true (the "
                                      "body on a face at the start)")
    if not scene.rough:
        return "[plane].friction", ("it needs [plane].friction > 0 (the face rests, slides "
                                    "and sticks by friction)")
    try:
        base_face(scene)
    except ValueError as exc:
        side = (" (a cylinder on its side touches the plane along a line, not a face: "
                "only its ends are faces)" if scene.shape == "cylinder" else "")
        return _attitude_field(scene), f"puts no face on the plane: {exc}{side}"
    n = np.asarray(scene.A0[2], dtype=float)
    w = np.asarray(scene.omega, dtype=float)
    if np.linalg.norm(cross(w, n)) > 1e-12 * max(np.linalg.norm(w), 1e-300):
        return "[initial].omega", ("is not along the vertical (a body on its face turns only "
                                   "about it)")
    c, cd = _base_offset(scene)
    v_O = np.asarray(scene.com_velocity, dtype=float) - scene.A0 @ (cross(w, c) + cd)
    scale = math.sqrt(scene.g * base_face(scene).size)          # (n is A0[2])
    if abs(v_O[2]) > 1e-12 * max(np.linalg.norm(v_O), scale):
        field = "[initial].com_velocity" if "com_velocity" in _initial(scene) \
            else "[initial].carrier_velocity"
        return field, (f"O starts with a vertical velocity ({v_O[2]:.3g} m/s): a body on its "
                       "face moves horizontally (give [initial].carrier_velocity = [V_x, V_y, "
                       "0])")
    return None


def _base_why(scene: Scene) -> str:
    face = base_face(scene)
    what = "box on a face" if face.kind == "rectangle" else "cylinder on an end"
    mu = f"mu = {scene.friction:g}" + (f", mu_s = {scene.mu_static:g}"
                                       if scene.mu_static != scene.friction else "")
    return (f"a {what} on a rough plane ({mu}): the face stays on the plane, so the "
            "horizontal motion and the yaw are the whole motion (Coulomb-Contensou friction "
            "over the face)")


def candidates(scene: Scene) -> list:
    wants = set(scene.outputs)
    if scene.rough and scene.on_plane and base_refusal(scene) is None:
        found = candidates(_off_face(scene))
        return [("base", _base_why(scene)), *found]
    if not scene.one_point:
        return [("moments_rough" if scene.rough else "moments", _moments_why(scene))]
    # a one-point scene's moments model, chosen only by [run].model (last: never auto)
    moments = ("moments_rough" if scene.rough else "moments",
               "the one point through its moments, as [run].model asks (the general "
               "model's motion at about 1.2 times its cost)")
    if scene.rough:
        return [("rough", f"the plane has friction (mu_f = {scene.friction:g}): the slip of "
                          "S needs the horizontal velocity of C and the whole attitude"),
                moments]
    out = []
    still, along_z, round_ = symmetry_key(scene.omega, scene.J)
    for kind, why in (("translational", _translational_reason(scene, still)),
                      ("planar", _planar_reason(scene, along_z)),
                      ("axisymmetric", _axisymmetric_reason(scene, still, round_))):
        if why:
            out.append((kind, why))
    if not scene.contact_possible and wants <= {"omega", "momentum"}:
        out.append(("attitude", "free flight and only omega/momentum asked: E1.7 alone"))
    if POSE not in wants:
        out.append(("vertical", "the pose is not asked: the horizontal motion of C is "
                                "uniform and the heading is not needed"))
    if not out:
        why = ("the pose is asked and no symmetry reduces the model" if POSE in wants
               else "no smaller model applies")
    else:                       # a smaller model answers too: general runs only if forced
        why = ("the paper's 18 states (E1.7, E1.8), which assume no symmetry and answer any "
               "one-point scene on a smooth plane")
    out.append(("general", why))
    out.append(moments)
    return out


def _off_face(scene: Scene) -> Scene:
    """The scene as the other models read it (on_plane only computes C's start)."""
    import dataclasses
    return dataclasses.replace(scene, on_plane=False)


def _touching_at_rest(scene: Scene) -> bool:
    """The body starts with S on the plane: ``[initial].on_plane``, or S at height 0 (to
    1e-9 of the body's size) not moving vertically (to 1e-9 of sqrt(g size))."""
    if scene.on_plane:
        return True
    if _initial(scene).get("on_plane"):
        return False        # the flight after a base run's lift-off (handover.flight_scene)
    n = np.asarray(scene.A0[2], dtype=float)
    s = lowest_point_numeric(scene, n)
    c, cd = _base_offset(scene)
    size = max(scene.size)
    if abs(scene.com[2] + n @ (s - c)) > 1e-9 * size:
        return False
    w = np.asarray(scene.omega, dtype=float)
    v_S = np.asarray(scene.com_velocity, dtype=float) + scene.A0 @ (cross(w, s - c) - cd)
    return abs(v_S[2]) <= 1e-9 * math.sqrt(scene.g * size)


def flat_start_refusal(scene: Scene, kind: str) -> tuple[str, str] | None:
    """(the attitude's field, the rule) when ``scene`` starts on the plane with a line or a
    face lowest (derive/face.py's flat_contact) and ``kind`` is not the base model, which
    alone takes a face: the one-point models chatter there (S jumps between the line's or
    the face's ends)."""
    if kind == "base" or not scene.contact_possible or scene.shape not in BASE_SHAPES:
        return None
    n = np.asarray(scene.A0[2], dtype=float)
    turn = cross(n, np.asarray(scene.omega, dtype=float)) * scene.duration
    what = faces.flat_contact(scene.shape, n, turn)
    # (placed by hand, a face at rest is what a base run's hand-over writes at its
    # lift-off, N = 0: the flight's; a line is refused either way)
    if what is None or not (scene.on_plane or (what in ("an edge", "its side (a line)")
                                               and _touching_at_rest(scene))):
        return None
    field = _attitude_field(scene)
    face = what in ("a face", "an end face")
    if faces.flat_contact(scene.shape, n) in ("a face", "an end face") and scene.rough \
            and scene.on_plane:
        found = base_refusal_at(scene)       # on a face, but not at rest on it: its cause
        if found is not None and found[0] != field:
            return found[0], (f"{found[1]}; so the base model (a body resting on a face) "
                              f"cannot run it, and model {kind} touches the plane at one "
                              "point, which would jump across the face (the run chatters)")
    if face:
        fix = ("stand it on the face exactly (the base model)" if scene.rough else
               "give [plane].friction > 0 (the base model: a body resting on a face)")
    else:
        fix = ("stand it on a face (the base model)" if scene.shape == "box" else
               "stand it on an end (the base model) or use a box")
    return field, (f"puts {shapes.with_article(scene.shape)} on the plane on {what}, the "
                   f"vertical {faces.vertical_text(n)} (body axes) within "
                   f"{faces.LINE_TOL:g} of it: "
                   f"model {kind} touches the plane at one point, which would jump across "
                   f"it (the run chatters); {fix}, or tilt it by more than "
                   f"{faces.LINE_TOL:g} rad so that one point is lowest")


def choose(scene: Scene) -> tuple[str, str]:
    """The model and why (for ``model = "auto"``), or the forced one checked."""
    if scene.model == "base":
        refusal = base_refusal(scene)
        if refusal is not None:
            raise SceneError("[run].model", f'"base" cannot run this scene: {refusal}')
    found = candidates(scene)
    if scene.model == "auto":
        kind, why = found[0]
    else:
        auto, auto_why = found[0]
        for kind, why in found:
            if kind == scene.model:
                why = (f"forced by [run].model, auto's choice too: {why}" if kind == auto
                       else f"forced by [run].model in place of auto's {auto} ({auto_why}); "
                            f"{kind}: {why}")
                break
        else:
            raise SceneError("[run].model", f"{scene.model!r} cannot answer this scene "
                                            f"(possible: {', '.join(k for k, _ in found)})")
    flat = flat_start_refusal(scene, kind)
    if flat is not None and not scene.restitution_given:
        raise SceneError(*flat)          # (before the restitution _base_keys would ask for)
    _base_keys(scene, kind)              # (the keys it refuses by name come first)
    if flat is not None:
        raise SceneError(*flat)
    return kind, why


# the keys the base model does not read (its own DOP853 in the time and in s, no attitude
# to keep orthonormal, no impacts), refused by name when given: key -> why
BASE_UNREAD = {
    "[run].method": "the base model integrates with its own DOP853 (in t along a line, "
                    "else in s = the slip's arc: derive/docs/bodies.md)",
    "[run].step": "is RK4's step, and the base model integrates with its own DOP853",
    "[run].keep_orthonormal": "the base model has no attitude matrix to keep orthonormal "
                              "(the yaw is one angle)",
}
# [plane].restitution, restitution_model and [run].zeno_dt are read by the flight after a
# lift-off (derive/runtime/handover.py): a face on the plane has no impacts itself


def _base_keys(scene: Scene, kind: str) -> None:
    """The keys only the base model reads are refused by name on the others; and what the
    base model does not read on it."""
    if kind != "base" and not scene.restitution_given and scene.plane:
        found = base_refusal_at(scene) if scene.on_plane else None
        if found is not None and found[0].startswith("[initial]"):
            # a start meant for the face that misses it: the cause first, then the key
            field, why = found
            raise SceneError(field, f"{why}; so the base model (a body resting on a face) "
                                    f"cannot run it, and this run is model {kind}, whose "
                                    "impacts need [plane].restitution: give it, or start "
                                    "the body on a face")
        why = f", not base: {base_refusal(scene)}" if found else ""
        raise SceneError("[plane].restitution", f"is required: this run is model {kind}{why} "
                                                "(only the base model, a body resting on "
                                                "its face, may leave it out)")
    if kind != "base":
        for f in SCENE_FIELDS:
            if f.models and kind not in f.models and getattr(scene, f.key) is not None:
                which = " and ".join(f.models)
                face = " (a box or a cylinder resting on a face)" if f.models == ("base",) \
                    else ""
                raise SceneError(f.where, f"is read by the {which} model only{face}, and "
                                          f"this run is model {kind}")
        _method_keys(scene, kind)
        return
    for key in ("spin_friction", "rolling_resistance"):
        if getattr(scene, key) > 0.0:
            raise SceneError(f"[plane].{key}", "is a couple at the one point S of the rough "
                                               "model; over a face the base model's friction "
                                               "gives the torques itself: remove it")
    if scene.control is not None:
        raise SceneError("[control]", "is not read by the base model (a body resting on its "
                                      "face has no controller yet): remove it")
    if scene.disturbance is not None:
        raise SceneError("[disturbance]", "is not read by the base model (a push would tilt "
                                          "the body off its face): remove it")
    for key, why in BASE_UNREAD.items():
        if key in scene.given:
            raise SceneError(key, f"is not read by the base model: {why}; remove it")


def _method_keys(scene: Scene, kind: str) -> None:
    """The [run] keys the run's method (or model) never reads are refused by name: a
    field's Field.methods, and keep_orthonormal where no step projects (a Lie method's
    flight stays on the rotations; its contact phases step with DOPRI5 or DOP853)."""
    for f in SCENE_FIELDS:
        if f.methods and scene.method not in f.methods and f.where in scene.given:
            which = " and ".join(f.methods)
            raise SceneError(f.where, f"is read by method {which} only, and this run's "
                                      f"method is {scene.method}: remove it, or set "
                                      f"[run].method = \"{f.methods[0]}\"")
    if not scene.keep_orthonormal:
        return
    if "a33" not in layout.of(kind).labels:
        raise SceneError("[run].keep_orthonormal", f"model {kind} has no attitude matrix to "
                                                   "keep orthonormal: remove it")
    if scene.method in abi.LIE_METHODS and not scene.contact_possible:
        raise SceneError("[run].keep_orthonormal", f"method {scene.method} keeps a flight's "
                                                   "attitude on the rotations itself, and "
                                                   "this run has no contact phase (the only "
                                                   "steps it would project): remove it, or "
                                                   "use dopri5, dop853 or rk4")


# ---- what a model reads ------------------------------------------------------------------------
def length_scale(scene: Scene) -> float:
    """The largest |CS| = |OS - nu OP|: the surface's reach from O plus the point's."""
    if not scene.size:
        return 0.0
    reach = math.hypot(*scene.center) + shapes.of(scene.shape).reach(scene.size)
    return reach + scene.nu * scene.law_summary.max_radius


@dataclass
class Start:
    """A model's initial state and the constants it reads from ``prm``."""
    q0: np.ndarray
    constants: dict


# the models whose start reads only C's position and velocity, omega and the attitude
# (a study's variants start in bulk: rows of com, com_velocity and omega give rows of q0)
POSE_STARTS = ("general", "rough", "vertical", "attitude", *MOMENTS_KINDS)


def start(scene: Scene, kind: str) -> Start:
    A0 = scene.A0
    if kind in POSE_STARTS:
        q = G.assemble(com=scene.com, com_velocity=scene.com_velocity, omega=scene.omega,
                       A=A0.reshape(-1))
        return Start(q if kind in GENERAL_STATE else layout.vertical_of_general(q)
                     if kind == "vertical" else q[..., G.omega], {})
    n0 = {"n0_x": A0[2][0], "n0_y": A0[2][1], "n0_z": A0[2][2]}
    if kind == "base":
        return _base_start(scene, n0)
    if kind == "translational":
        return Start(np.array([scene.com[2], scene.com_velocity[2]]), n0)
    jets = scene.law.jets([scene.t0])[:, 0]
    if kind == "planar":
        K = kinetic_moment(scene, np.array([[0.0, 0.0, scene.omega[2]]]), jets[:, None])[0]
        return Start(np.array([scene.com[2], scene.com_velocity[2], K[2], 0.0]), n0)
    if kind == "axisymmetric":
        K_body = kinetic_moment(scene, np.asarray([scene.omega], dtype=float), jets[:, None])[0]
        K, R_K, psi0, theta0, phi0 = momentum_frame(A0 @ K_body, A0)
        st = Start(np.array([psi0, phi0]), {"K": K, "omega_z0": scene.omega[2]})
        st.constants["_frame"] = (R_K, theta0)
        return st
    raise KeyError(kind)


def _base_start(scene: Scene, n0: dict) -> Start:
    """(X_O, Y_O, psi, X_O', Y_O', psi'): O from C and the bodies' offset, psi the yaw of
    the face frame (A0 = R_z(psi) Q), psi' the spin about the vertical."""
    A0 = np.asarray(scene.A0, dtype=float)
    face = base_face(scene)
    c, cd = _base_offset(scene)
    w = np.asarray(scene.omega, dtype=float)
    r_O = np.asarray(scene.com, dtype=float) - A0 @ c
    v_O = np.asarray(scene.com_velocity, dtype=float) - A0 @ (cross(w, c) + cd)
    F = A0 @ face.frame.T
    psi = math.atan2(F[1, 0], F[0, 0])
    q0 = np.array([r_O[0], r_O[1], psi, v_O[0], v_O[1], float(A0[2] @ w)])
    pressure = float(faces.PRESSURES.index(scene.pressure or "uniform"))
    return Start(q0, {**n0, "static_friction": scene.mu_static, "pressure": pressure,
                      "_face": face,
                      "_Z_O": float(r_O[2])})


def base_pose(scene: Scene, st: Start, t, Q) -> tuple:
    """Along the rows of a base run: the attitude A = R_z(psi) Q_face (n, 3, 3), O's
    position and velocity (n, 3) and omega in body axes (psi' along the vertical)."""
    n = len(t)
    B = layout.BASE
    Qf = st.constants["_face"].frame
    A = rotation_z(Q[:, B.psi]) @ Qf[None]
    r_O = np.column_stack([Q[:, B.position], np.full(n, st.constants["_Z_O"])])
    v_O = np.column_stack([Q[:, B.velocity], np.zeros(n)])
    omega = Q[:, B.psi_rate][:, None] * np.asarray(scene.A0[2], dtype=float)[None]
    return A, r_O, v_O, omega


def base_c(scene: Scene, st: Start, t, Q) -> tuple:
    """C's position and velocity (fixed axes) and the attitude along the rows of a base
    run: r_C = r_O + A OC, V_C = V_O + A (omega x OC + OC')."""
    from . import bodies
    A, r_O, v_O, omega = base_pose(scene, st, t, Q)
    c, cd, _ = bodies.offsets_at(scene, t)
    r_C = r_O + np.einsum("nij,nj->ni", A, c)
    v_C = v_O + np.einsum("nij,nj->ni", A, cross(omega, c) + cd)
    return r_C, v_C, A, omega


_P = abi.PRM
_P_BODY = (_P["M"], _P["m"], _P["J_x"], _P["J_y"], _P["J_z"], _P["g"], _P["e"])
_RESTITUTION = {name: float(k) for k, name in enumerate(abi.names(abi.RESTITUTION_MODELS))}
_P_SHAPE = (_P["size_a"], _P["size_b"], _P["size_c"], _P["center_x"], _P["center_y"],
            _P["center_z"])


def vector(entries: list) -> np.ndarray:
    """An option or parameter vector from its entries; where some are columns (a study's
    variants at once, derive.scene.bulk), one row per variant."""
    try:
        return np.array(entries, dtype=float)
    except ValueError:                   # columns among the numbers
        return np.stack(np.broadcast_arrays(*entries), axis=-1).astype(float)


def parameters(scene: Scene, constants: dict) -> np.ndarray:
    """The parameter vector of a run (indices from abi.PARAMETERS), built as a list and
    made an array once (an item set on an array costs ten times a list's); rows of them
    for a Scene whose numbers are a study's columns."""
    prm = [0.0] * len(abi.PARAMETERS)
    e = scene.e if scene.restitution_given or not scene.plane else 0.0   # (NaN: not read)
    for k, x in zip(_P_BODY, (scene.M, scene.m, *scene.J, scene.g, e)):
        prm[k] = x
    if scene.friction:
        prm[_P["friction"]] = scene.friction
        prm[_P["restitution_model"]] = _RESTITUTION[scene.restitution_model]
        prm[_P["spin_friction"]] = scene.spin_friction
        prm[_P["rolling_resistance"]] = scene.rolling_resistance
    if scene.size:                     # (the sizes in their slots, then the centre)
        prm[_P["shape"]] = float(shapes.SHAPE_NAMES.index(scene.shape))
        for k, x in zip(_P_SHAPE, (*scene.size, 0.0, 0.0, 0.0)[:3] + tuple(scene.center)):
            prm[k] = x
    for name, value in constants.items():
        if not name.startswith("_"):
            prm[_P[name]] = float(value)
    _bodies(prm, scene)
    return vector(prm)


def _bodies(prm: list, scene: Scene) -> None:
    """The internal bodies' parameters (abi: n_points, n_rotors, m_j, a_r_x.., I_r)."""
    points, rotors = scene.points, scene.rotors
    prm[_P["n_points"]], prm[_P["n_rotors"]] = float(len(points)), float(len(rotors))
    for j, point in enumerate(points, start=1):
        prm[_P[f"m_{j}"]] = point.mass
    for r, rotor in enumerate(rotors, start=1):
        for c, x in zip("xyz", rotor.axis):
            prm[_P[f"a_{r}_{c}"]] = x
        prm[_P[f"I_{r}"]] = rotor.inertia


# ---- results in the general layout -------------------------------------------------------------
def _uniform_horizontal(scene: Scene, t):
    dt = np.asarray(t) - scene.t0
    return (scene.com[0] + scene.com_velocity[0] * dt, scene.com[1] + scene.com_velocity[1] * dt,
            np.full_like(dt, scene.com_velocity[0]), np.full_like(dt, scene.com_velocity[1]))


def omega_of(scene: Scene, kind: str, st: Start, t, Q, rates=None) -> np.ndarray:
    """omega in body axes along the rows; ``rates`` (dq/dt of the rows, from the library)
    for the models whose omega is a rate (planar: phi', axisymmetric: psi')."""
    n = len(t)
    if kind in ("vertical", "attitude", *GENERAL_STATE):
        return Q[:, layout.of(kind).omega]
    if kind == "base":
        return base_pose(scene, st, t, Q)[3]
    if kind == "translational":
        return np.zeros((n, 3))
    if kind == "planar":
        return np.column_stack([np.zeros(n), np.zeros(n), rates[:, layout.PLANAR.phi]])
    if kind == "axisymmetric":
        _, theta0 = st.constants["_frame"]
        s0 = np.sin(theta0)
        psi_rate, phi = rates[:, layout.AXISYMMETRIC.psi], Q[:, layout.AXISYMMETRIC.phi]
        return np.column_stack([psi_rate * s0 * np.sin(phi), psi_rate * s0 * np.cos(phi),
                                np.full(n, st.constants["omega_z0"])])
    raise KeyError(kind)


def to_general(scene: Scene, kind: str, st: Start, t, Q, omega) -> np.ndarray | None:
    """The rows in the general layout (None for models that cannot give the pose)."""
    n = len(t)
    A0 = scene.A0
    if kind in GENERAL_STATE:
        return Q
    if kind in ("vertical", "attitude"):
        return None
    if kind == "base":
        r_C, v_C, A, omega = base_c(scene, st, t, Q)
        return G.assemble(com=r_C, com_velocity=v_C, omega=omega, A=A.reshape(n, 9))
    X, Y, VX, VY = _uniform_horizontal(scene, t)
    if kind == "translational":
        T = layout.TRANSLATIONAL
        return _general_rows(X, Y, Q[:, T.Z], VX, VY, Q[:, T.Zd], np.zeros((n, 3)),
                             np.tile(A0.reshape(-1), (n, 1)))
    if kind == "planar":
        P = layout.PLANAR
        A = A0[None] @ rotation_z(Q[:, P.phi])
        return _general_rows(X, Y, Q[:, P.Z], VX, VY, Q[:, P.Zd], omega, A.reshape(n, 9))
    if kind == "axisymmetric":
        S = layout.AXISYMMETRIC
        R_K, theta0 = st.constants["_frame"]
        dt = np.asarray(t) - scene.t0
        Z = scene.com[2] + scene.com_velocity[2] * dt - 0.5 * scene.g * dt ** 2
        VZ = scene.com_velocity[2] - scene.g * dt
        A = (R_K[None] @ rotation_z(Q[:, S.psi]) @ rotation_x(np.full(n, theta0))
             @ rotation_z(Q[:, S.phi]))
        return _general_rows(X, Y, Z, VX, VY, VZ, omega, A.reshape(n, 9))
    raise KeyError(kind)


def _general_rows(X, Y, Z, VX, VY, VZ, omega, A) -> np.ndarray:
    return G.assemble(com=np.column_stack([X, Y, Z]), com_velocity=np.column_stack([VX, VY, VZ]),
                      omega=omega, A=A)


def height_of_c(scene: Scene, kind: str, t: float, q) -> float:
    """Z_C at time t from one state of a model (NaN for the attitude model); from rows of
    states, a column, for the models whose state holds it."""
    if kind in ("vertical", "translational", "planar", *GENERAL_STATE):
        z = q[..., layout.of(kind).Z]
        return float(z) if np.ndim(z) == 0 else z
    if kind == "base":
        return float(base_c_at(scene, t, q)[2])
    if kind == "axisymmetric":                # free flight: C on its parabola
        dt = t - scene.t0
        return scene.com[2] + scene.com_velocity[2] * dt - 0.5 * scene.g * dt * dt
    return math.nan


def base_c_at(scene: Scene, t: float, q, st: Start | None = None) -> np.ndarray:
    """C's position at time t from one state of the base model (``st``: the run's start,
    if at hand)."""
    st = start(scene, "base") if st is None else st
    return base_c(scene, st, np.array([float(t)]), np.asarray(q, dtype=float)[None])[0][0]


def horizontal_of_c(kind: str, t0, t, q, c0, scenes=None) -> tuple:
    """(X_C, Y_C) at time t from a state of a model and C's start ``c0`` (X, Y, Z, X', Y',
    Z'), of one run or entry by entry of rows.  A model whose state holds them (the
    general state: general, rough, moments, moments_rough) is read; every other model runs
    on a smooth plane or in free flight, where nothing horizontal acts on the system, so C
    moves uniformly: X_C = X_C0 + X_C0' (t - t0).  The base model (friction over a face)
    reads the scene (``scenes``: one, or one per row): C = O + A OC."""
    if "horizontal" in layout.of(kind).parts:
        h = q[..., layout.of(kind).horizontal]
        return h[..., 0], h[..., 1]
    if kind == "base":
        if np.ndim(t) == 0:
            r = base_c_at(scenes, t, q)
            return float(r[0]), float(r[1])
        r = np.array([base_c_at(sc, tk, qk) for sc, tk, qk in zip(scenes, t, q)])
        return r[:, 0], r[:, 1]
    c0 = np.asarray(c0, dtype=float)
    dt = np.asarray(t, dtype=float) - t0
    return c0[..., 0] + c0[..., 3] * dt, c0[..., 1] + c0[..., 4] * dt


def start_of_c(scene) -> np.ndarray:
    """C's position and velocity at the start (X, Y, Z, X', Y', Z'), or rows of them."""
    return np.concatenate([np.asarray(scene.com, dtype=float),
                           np.asarray(scene.com_velocity, dtype=float)], axis=-1)


def travel(kind: str, t0, t_end, q, c0, scenes=None) -> dict:
    """Where C ends horizontally and how far it went from its start (the net horizontal
    displacement), of one run or entry by entry (``scenes``: horizontal_of_c's)."""
    return displacement(*horizontal_of_c(kind, t0, t_end, q, c0, scenes), c0)


def displacement(x, y, c0) -> dict:
    """travel's columns from where C ends horizontally (x, y) and its start ``c0``."""
    c0 = np.asarray(c0, dtype=float)
    distance = np.hypot(x - c0[..., 0], y - c0[..., 1])
    one = np.ndim(distance) == 0
    return {"X_C_end": float(x) if one else x, "Y_C_end": float(y) if one else y,
            "distance": float(distance) if one else distance}


def vertical_of(kind: str, general, Q) -> tuple | None:
    """(Z_C, n) along the rows, for the height of S."""
    if general is not None:
        return general[:, G.Z], general[:, G.n]
    if kind == "vertical":
        V = layout.VERTICAL
        return Q[:, V.Z], Q[:, V.n]
    return None

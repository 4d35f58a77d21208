"""Scenes for the verifiers: random valid bouncing scenes, and hostile ones.

* :func:`random_scene`: a random valid bouncing scene (spheres and ellipsoids with offset
  centres, M and m with m > M included, near-symmetric and strongly asymmetric inertia,
  laws of 1-3 harmonics up to 30% of the body's size and 15 rad/s, spins up to 20 rad/s,
  restitution in {0, 0.1, 0.5, 0.9, 1} or random, durations up to 60 s, every method);
  ``derive verify robustness`` runs thousands.
* :func:`generate`: seeded hostile cases (a :class:`Case` each, with what the README says
  must happen to it) in four families, written from the README's contract, not from
  the parser's code:

  - ``scene``: mutations of a valid scene: wrong types, NaN and infinities, huge, tiny
    and negative numbers, big integers, missing and extra keys, wrong list shapes,
    hostile strings (C/Python/shell injection, control characters, unicode digits and
    spaces, very long text) in every string field, deep nesting;
  - ``law``: random laws of the README's grammar (:mod:`derive.verify.laws`), planted
    poles and non-smooth points, hostile tokens;
  - ``table``: tabulated laws (``[point] table = "file.csv"`` or ``samples``) with paths
    that climb out (``..``, absolute, symlinks, FIFOs, devices) and huge, ragged or
    non-numeric files;
  - ``toml``: text the TOML reader itself must survive (deep arrays, bad bytes, size).
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

import numpy as np

from .laws import EITHER_LAWS, HOSTILE_LAWS, deep_laws, law_text, planted_law, random_law
from ..scene import toml
from ..scene.errors import printable
from ..scene.overrides import delete_path as _del, set_path as _set


# ---- random valid scenes ------------------------------------------------------------
METHODS = ("lie", "lie5", "lie8", "dopri5", "dop853", "rk4")
RESTITUTIONS = (0.0, 0.1, 0.5, 0.9, 1.0)


def _harmonics(rng, amp: float, max_w: float = 15.0) -> str:
    terms = []
    for _ in range(int(rng.integers(1, 4))):
        a = rng.uniform(-amp, amp) / 2
        w = rng.uniform(0.5, max_w)
        ph = rng.uniform(0, 2 * math.pi)
        terms.append(f"{a:.6g}*sin({w:.6g}*t + {ph:.6g})")
    return " + ".join(terms)


def random_scene(rng: np.random.Generator, max_duration: float = 60.0,
                 method: str | None = None) -> dict:
    """A random valid bouncing scene (a dict of the schema)."""
    shape = "sphere" if rng.random() < 0.5 else "ellipsoid"
    size = rng.uniform(0.1, 1.0)
    if shape == "sphere":
        geom = {"radius": size}
    else:
        axes = size * rng.uniform(0.4, 1.0, 3)
        axes[rng.integers(3)] = size
        geom = {"semi_axes": [float(a) for a in axes]}
    center = (rng.uniform(-0.3, 0.3, 3) * size if rng.random() < 0.6 else np.zeros(3))
    M = rng.uniform(0.2, 5.0)
    m = M * (rng.uniform(0.05, 2.0) if rng.random() < 0.8 else rng.uniform(1.0, 4.0))
    if rng.random() < 0.3:                          # near-symmetric
        base = rng.uniform(0.05, 1.0) * M * size ** 2
        J = base * (1 + rng.uniform(-1e-3, 1e-3, 3))
    else:                                           # from a real mass distribution
        second = rng.uniform(0.02, 1.0, 3) * M * size ** 2
        J = np.array([second[1] + second[2], second[0] + second[2], second[0] + second[1]])
    amp = 0.3 * size
    law = [_harmonics(rng, amp) if rng.random() < 0.8 else f"{rng.uniform(-amp, amp):.6g}"
           for _ in range(3)]
    e = float(rng.choice(RESTITUTIONS)) if rng.random() < 0.6 else float(rng.uniform(0, 1))
    spin = rng.normal(size=3)
    spin *= rng.uniform(0, 20) / max(np.linalg.norm(spin), 1e-12)
    quat = rng.normal(size=4)
    # start high enough: the lowest point of any attitude is within |center| + size of O
    z0 = float(np.linalg.norm(center) + size + 0.35 * size + rng.uniform(0.0, 2.0))
    return {
        "name": "random",
        "body": {"mass": float(M), "inertia": [float(j) for j in J], "shape": shape, **geom,
                 "center": [float(c) for c in center]},
        "point": {"mass": float(m), "law": law},
        "plane": {"restitution": e},
        "initial": {"com": [0.0, 0.0, z0],
                    "com_velocity": [float(v) for v in rng.normal(0, 1, 2)]
                    + [float(rng.normal(0, 2))],
                    "omega": [float(w) for w in spin], "quaternion": [float(x) for x in quat]},
        "run": {"duration": float(rng.uniform(1.0, max_duration)),
                "method": method or str(rng.choice(METHODS)),
                "rtol": float(10 ** rng.uniform(-11, -7)), "atol": 1e-12,
                "outputs": ["pose", "impacts"]},
    }


def random_rough_scene(rng: np.random.Generator, max_duration: float = 20.0,
                       method: str | None = None, couples: bool = False) -> dict:
    """A random valid scene on a rough plane: :func:`random_scene`'s bodies, laws and
    starts, with mu_f from 0.05 to 1.5 (a fifth of them above 1), the restitution law
    energetic or poisson, restitution in {0, 0.1, 0.5, 0.9} or random (mostly low: the
    impacts accumulate into sliding and sticking), and a third of them starting on the
    plane, sliding and spinning.  ``couples``: also spin friction and rolling resistance,
    each up to 30% of the body's size (one of them 0 in a third of the scenes)."""
    doc = random_scene(rng, max_duration, method)
    mu = rng.uniform(1.0, 1.5) if rng.random() < 0.2 else rng.uniform(0.05, 1.0)
    e = float(rng.choice((0.0, 0.1, 0.5, 0.9))) if rng.random() < 0.7 \
        else float(rng.uniform(0, 1))
    doc["plane"] = {"restitution": e, "friction": float(mu),
                    "restitution_model": str(rng.choice(("energetic", "poisson")))}
    if rng.random() < 0.33:
        # resting on the plane: S at the plane's height (1e-9 above it), moving
        # horizontally and spinning
        from ..scene.law import compile_law
        from ..scene.rules import rotation_from_quaternion
        radius = doc["body"].get("radius")
        axes = np.array([radius] * 3 if radius else doc["body"]["semi_axes"])
        A = rotation_from_quaternion(doc["initial"]["quaternion"])
        D2n = axes ** 2 * A[2]
        s = np.asarray(doc["body"]["center"]) - D2n / math.sqrt(float(A[2] @ D2n))
        M, m = doc["body"]["mass"], doc["point"]["mass"]
        r = compile_law(tuple(doc["point"]["law"])).point(0.0)[:3]
        doc["initial"]["com"][2] = float(-(A @ (s - m / (M + m) * np.asarray(r)))[2]) + 1e-9
        doc["initial"]["com_velocity"][2] = 0.0
    doc["run"]["duration"] = float(min(doc["run"]["duration"], max_duration))
    if couples:
        size = doc["body"].get("radius") or max(doc["body"]["semi_axes"])
        mu_s, mu_r = rng.uniform(0.0, 0.3, 2) * size
        which = rng.random()
        doc["plane"]["spin_friction"] = float(mu_s) if which > 1 / 6 else 0.0
        doc["plane"]["rolling_resistance"] = float(mu_r) if which < 5 / 6 else 0.0
    return doc


def random_bodies_scene(rng: np.random.Generator, max_duration: float = 5.0,
                        method: str | None = None, rough: bool = False,
                        n_points: int | None = None, n_rotors: int | None = None) -> dict:
    """A random valid scene of several internal bodies (the moments models): the body,
    plane and start of :func:`random_scene` with its point given as ``n_points`` points
    (0 to 6 unless given; random masses, harmonic laws) and ``n_rotors`` rotors (0 to 3:
    a random unit axis, an axial moment up to a tenth of the smallest J, a spin up to 60
    rad/s and harmonics), started high enough for any law; ``rough``: a rough plane as
    :func:`random_rough_scene`'s (mu_f, restitution and its law), started above it."""
    doc = random_scene(rng, max_duration, method)
    n_points = int(rng.integers(0, 7)) if n_points is None else n_points
    n_rotors = int(rng.integers(0, 4)) if n_rotors is None else n_rotors
    body = doc["body"]
    size = body.get("radius") or max(body["semi_axes"])
    M, J = body["mass"], body["inertia"]
    amp = 0.3 * size / max(n_points, 1) ** 0.5
    doc["point"] = [{"mass": float(M * rng.uniform(0.02, 0.6)),
                     "law": [_harmonics(rng, amp) for _ in range(3)]}
                    for _ in range(n_points)]
    rotors = []
    for _ in range(n_rotors):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        rotors.append({"axis": [float(a) for a in axis],
                       "inertia": float(0.1 * min(J) * rng.uniform(0.05, 1.0)),
                       "law": f"{rng.uniform(-60, 60):.6g}*t + {_harmonics(rng, 2.0, 20.0)}"})
    if rotors:
        doc["rotor"] = rotors
    if not doc["point"]:
        doc.pop("point")
    if rough:
        doc["plane"] = {"restitution": float(rng.choice((0.0, 0.1, 0.5, 0.9))),
                        "friction": float(rng.uniform(0.05, 1.5)),
                        "restitution_model": str(rng.choice(("energetic", "poisson")))}
    # S is within |center| + size of O, and OC within the points' reach of it
    doc["initial"]["com"][2] = float(np.linalg.norm(body["center"]) + 1.6 * size
                                     + rng.uniform(0.0, 1.0))
    return doc


# the attitudes that put a face down (quaternions w, x, y, z: the body's -z, +z, -x, +x,
# -y, +y face on the plane); a cylinder rests on an end (the first two)
_FACE_DOWN = ((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.5 ** 0.5, 0.0, 0.5 ** 0.5, 0.0),
              (0.5 ** 0.5, 0.0, -(0.5 ** 0.5), 0.0), (0.5 ** 0.5, -(0.5 ** 0.5), 0.0, 0.0),
              (0.5 ** 0.5, 0.5 ** 0.5, 0.0, 0.0))


def random_face_scene(rng: np.random.Generator, max_duration: float = 3.0) -> dict:
    """A random valid body on its face (the base model): a box on any of its six faces or
    a cylinder on an end, yawed at random, its centre off O by up to a fifth of its size,
    with one to three points on harmonic laws (up to a fifth of the size) and a rotor in
    half the scenes; friction 0.05 to 1, static friction above it in half, uniform or
    linear pressure; at rest or sliding and spinning (horizontally, omega along the
    vertical).  A fifth hop (one point's law along one body axis pushes N through 0: if
    that axis is the vertical, the body lifts off); others tip or lift the face (the
    points' sway): the judge holds each stop to its time."""
    from ..scene.rules import rotation_from_quaternion
    shape = "box" if rng.random() < 0.6 else "cylinder"
    if shape == "box":
        half = rng.uniform(0.03, 0.15, 3)
        geom = {"half_extents": [float(h) for h in half]}
        size, small = float(max(half)), float(min(half))
        faces = _FACE_DOWN
    else:
        R, L = rng.uniform(0.03, 0.15), rng.uniform(0.01, 0.1)
        geom = {"radius": float(R), "half_length": float(L)}
        size, small, faces = float(max(R, L)), float(min(R, L)), _FACE_DOWN[:2]
    M = float(rng.uniform(0.3, 3.0))
    second = rng.uniform(0.05, 0.3, 3) * M * size ** 2
    J = [float(second[1] + second[2]), float(second[0] + second[2]), float(second[0] + second[1])]
    amp = 0.3 * small                              # (most stay within the kern a while)
    points = [{"mass": float(M * rng.uniform(0.05, 0.5)),
               "law": [_harmonics(rng, amp, 25.0) for _ in range(3)]}
              for _ in range(int(rng.integers(1, 4)))]
    hop = rng.random() < 0.15
    doc = {"name": "random-face",
           "body": {"mass": M, "inertia": J, "shape": shape, **geom,
                    "center": [float(c) for c in rng.uniform(-0.2, 0.2, 3) * small]},
           "point": points,
           "plane": {"friction": float(rng.uniform(0.05, 1.0)),
                     "pressure": str(rng.choice(("uniform", "linear")))}}
    if rng.random() < 0.5:
        doc["plane"]["static_friction"] = float(doc["plane"]["friction"]
                                                * rng.uniform(1.0, 1.4))
    if rng.random() < 0.5:
        axis = rng.normal(size=3)
        doc["rotor"] = [{"axis": [float(a) for a in axis / np.linalg.norm(axis)],
                         "inertia": float(0.1 * min(J) * rng.uniform(0.05, 1.0)),
                         "law": _harmonics(rng, 3.0, 20.0)}]
    w, x, y, z = faces[int(rng.integers(len(faces)))]
    yaw = rng.uniform(-math.pi, math.pi) / 2
    c, s_ = math.cos(yaw), math.sin(yaw)           # (cos, 0, 0, sin) * (w, x, y, z)
    quat = [c * w - s_ * z, c * x - s_ * y, c * y + s_ * x, c * z + s_ * w]
    n = rotation_from_quaternion(quat)[2]          # the vertical in body axes
    if hop:
        # one point bobbing along the vertical over the face's centre, the shape centred:
        # N = (M + m) g + m z'' reaches 0 with no moment to tip it (a moment would send cp
        # to the edge first, cp = moment/N): the body lifts off
        axis, m, f = int(np.argmax(np.abs(n))), M * rng.uniform(0.3, 0.6), rng.uniform(20, 30)
        a = (M + m) * 9.81 / (m * f * f) * rng.uniform(1.1, 2.0)
        law = ["0", "0", "0"]
        law[axis] = f"{a:.6g}*sin({f:.6g}*t)"
        doc["point"] = [{"mass": float(m), "law": law, "max_distance": float(2 * a + size)}]
        doc["body"]["center"] = [0.0, 0.0, 0.0]
        doc.pop("rotor", None)
    moving = rng.random() < 0.5
    v = rng.normal(0, 0.2, 2) if moving else np.zeros(2)
    doc["initial"] = {"on_plane": True, "quaternion": [float(q) for q in quat],
                      "carrier_velocity": [float(v[0]), float(v[1]), 0.0],
                      "omega": [float(rng.normal(0, 2.0) * k) if moving else 0.0 for k in n]}
    doc["run"] = {"duration": float(rng.uniform(0.2, max_duration))}
    return doc


def with_rk4_step(doc: dict, rng) -> dict:
    """RK4 has no error control: give it a step that resolves fast spins (a user of RK4
    chooses its step; the default is for slow scenes)."""
    if doc["run"]["method"] == "rk4":
        doc["run"]["step"] = float(rng.uniform(1e-3, 2e-3))
    return doc


# ---- hostile cases ------------------------------------------------------------------
def base_scene(duration: float = 1.0) -> dict:
    """The README's scene, 1 s long (a few impacts, milliseconds to run)."""
    return {
        "name": "bouncing-ball",
        "body": {"mass": 1.0, "inertia": [0.10, 0.12, 0.14], "shape": "sphere",
                 "radius": 0.5, "center": [0.0, 0.0, 0.0]},
        "point": {"mass": 0.2, "law": ["0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"]},
        "plane": {"restitution": 0.9},
        "initial": {"time": 0.0, "com": [0.0, 0.0, 1.5], "com_velocity": [0.3, 0.0, 0.0],
                    "omega": [0.5, -0.3, 1.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
        "run": {"duration": duration, "method": "dopri5", "rtol": 1e-10, "atol": 1e-12,
                "g": 9.81, "outputs": ["pose", "impacts"]},
    }


def table_rows(n: int = 101, t1: float = 1.0) -> list:
    t = np.linspace(0.0, t1, n)
    return [[float(a), float(0.1 * math.sin(3 * a)), 0.1, float(0.05 * math.cos(2 * a))]
            for a in t]


def csv_text(rows, header: str = "t,x,y,z") -> str:
    return header + "\n" + "".join(",".join(repr(v) for v in r) + "\n" for r in rows)


# ---- the case ----------------------------------------------------------------------
@dataclass
class Case:
    index: int
    family: str                       # scene, law, table, toml, explicit
    desc: str
    doc: dict | None = None           # the scene as a dict (serialised for the CLI)
    text: str | bytes | None = None   # or as TOML text
    files: dict = field(default_factory=dict)   # name -> bytes | ("symlink", target) |
    #                                             ("fifo",) | ("dir",)
    expect: str = "either"            # refuse | either | accept
    fields: tuple | None = ()         # a refusal must name one of these (None: any line)
    laws: dict = field(default_factory=dict)    # component -> tree (the law oracle)
    window: tuple = (0.0, 1.0)
    size: float = 0.5                 # body size (the oracle's bound)
    toml_level_ok: bool = False       # the TOML reader may refuse it (nesting depth)

    def short(self) -> str:
        d = self.desc if len(self.desc) < 110 else self.desc[:100] + "...(" + \
            f"{len(self.desc)} chars)"
        return d.encode("unicode_escape").decode("ascii")


# ---- hostile strings, numbers and mutations ---------------------------------------------
def hostile_strings(marker: str) -> list:
    return [
        f'*/ __attribute__((constructor)) static void pwn(void){{system("touch {marker}");}} /*',
        f'$(touch {marker})', f'`touch {marker}`', f'"; import os; os.system("touch {marker}"); "',
        f"'; touch {marker}; '", f'\\"); system("touch {marker}"); //', '\x00', '\n', '\r\n',
        '../../../../x', '/etc/passwd', '..', '.', '', ' ', 'con', 'a/b', '\u202etxt.exe',
        'A' * 100_000, '%s%n%x', '{{7*7}}', '{% include "/etc/passwd" %}', '${HOME}', '\\',
        '\U0001f642', '\u0660\u0661', '#include </dev/random>', '\x1b[2J', '-o /tmp/x',
        '<script>', 'DOPRI5', 'dopri5 ', ' dopri5', 'dopri\uff15', 'sphere\x00',
    ]


# ---- scene mutations ---------------------------------------------------------------
NUMBER_FIELDS = {      # path: rule  (pos: > 0, nonneg, unit: [0, 1], any, count)
    ("body", "mass"): "pos", ("point", "mass"): "pos", ("body", "radius"): "pos",
    ("plane", "restitution"): "unit", ("initial", "time"): "any",
    ("run", "duration"): "pos", ("run", "rtol"): "pos", ("run", "atol"): "pos",
    ("run", "g"): "any", ("run", "step"): "pos", ("run", "output_dt"): "nonneg",
    ("run", "max_events"): "count", ("run", "max_steps"): "count", ("run", "zeno_dt"): "pos",
}
VECTOR_FIELDS = {
    ("body", "inertia"): "pos", ("body", "center"): "any", ("initial", "com"): "any",
    ("initial", "com_velocity"): "any", ("initial", "omega"): "any",
    ("initial", "quaternion"): "quat",
}
RELATED = {
    "[body].mass": ["[point].mass", "[body].inertia"],
    "[point].mass": ["[body].mass", "[body].inertia"],
    "[body].inertia": ["[body].mass", "[point].mass", "[point].law"],
    "[body].radius": ["[point].law", "[initial].com", "[body].center", "[body].shape"],
    "[body].semi_axes": ["[point].law", "[initial].com", "[body].center", "[body].shape"],
    "[body].center": ["[point].law", "[initial].com", "[body].radius"],
    "[initial].com": ["[body].radius", "[body].center", "[body].shape"],
    "[initial].time": ["[run].duration"],
    "[run].duration": ["[initial].time", "[run].step", "[run].max_steps", "[run].output_dt",
                       "[run].zeno_dt", "[point].law", "[point].samples", "[point].table"],
    "[run].step": ["[run].duration", "[run].max_steps"],
    "[run].output_dt": ["[run].duration"],
    "[run].zeno_dt": ["[run].duration"],
    "[run].rtol": ["[run].atol"], "[run].atol": ["[run].rtol"],
    "[run].max_steps": ["[run].duration", "[run].step", "[point].law", "[point].samples",
                        "[point].table"],
    "[initial].quaternion": ["[initial].matrix"],
}


def fname(path) -> str:
    if isinstance(path, str):
        return path
    if len(path) == 1:
        return path[0]
    return f"[{path[0]}]." + ".".join(path[1:])


def fields_for(path) -> tuple:
    f = fname(path)
    return (f, *RELATED.get(f, ()))


def _deep_list(depth: int, leaf=1.0):
    v = leaf
    for _ in range(depth):
        v = [v]
    return v


def _deep_dict(depth: int):
    v = {"a": 1.0}
    for _ in range(depth):
        v = {"a": v}
    return v


NONFINITE = (math.nan, math.inf, -math.inf)
HUGE = (1e308, -1e308, 1.7976931348623157e308, 1e200)
BIGINT = (2 ** 63 - 1, 2 ** 63, 10 ** 30, -(2 ** 63), 2 ** 64 + 1, 10 ** 400)
TINY = (1e-300, 5e-324, 2.2250738585072014e-308, 1e-320)
WRONG_TYPES = ("1.0", "", True, False, [1.0], {"a": 1.0}, [], "nan", "0x10", "\uff11")


def scene_mutation(rng: random.Random, index: int, marker: str) -> Case:
    doc = base_scene()
    r = rng.random()
    if r < 0.35:          # a number
        path, rule = rng.choice(list(NUMBER_FIELDS.items()))
        kind = rng.choice(("nonfinite", "huge", "bigint", "tiny", "zero", "negative",
                           "wrongtype", "int", "deep", "mid"))
        expect = "either"
        if kind == "nonfinite":
            v = rng.choice(NONFINITE)
            expect = "refuse"
        elif kind == "huge":
            v = rng.choice(HUGE)
            expect = "refuse" if rule != "count" or v < 0 else "either"
        elif kind == "bigint":
            v = rng.choice(BIGINT)
            expect = "refuse" if rule != "count" or v < 0 or v >= 2 ** 63 else "either"
        elif kind == "tiny":
            v = rng.choice(TINY)
            expect = "refuse" if rule in ("count",) else "either"
        elif kind == "zero":
            v = rng.choice((0.0, -0.0, 0))
            expect = "refuse" if rule in ("pos",) else "either"
        elif kind == "negative":
            v = rng.choice((-1.0, -1e-12, -5))
            expect = "refuse" if rule in ("pos", "nonneg", "unit", "count") else "either"
            if path == ("run", "g"):
                expect = "either"
        elif kind == "wrongtype":
            v = rng.choice(WRONG_TYPES)
            expect = "refuse"
        elif kind == "int":
            v = rng.choice((1, 2, 3))
            expect = "either"
        elif kind == "deep":
            v = _deep_list(rng.choice((2, 50, 5000)))
            expect = "refuse"
        else:                 # 1e30, 1.5 for counts
            v = rng.choice((1e30, 1e15, 1.5, 1e-30))
            expect = "either"
            if rule == "unit" and v > 1:
                expect = "refuse"
        if path == ("run", "step"):
            doc["run"]["method"] = "rk4"
        _set(doc, path, v)
        return Case(index, "scene", f"{fname(path)} = {_short(v)}", doc, expect=expect,
                    fields=fields_for(path), toml_level_ok=kind == "deep")
    if r < 0.55:          # a vector
        path, rule = rng.choice(list(VECTOR_FIELDS.items()))
        base = list(doc[path[0]][path[1]])
        kind = rng.choice(("element", "length", "scalar", "wrongtype", "nested", "deep",
                           "zero"))
        expect = "refuse"
        if kind == "element":
            k = rng.randrange(len(base))
            v = rng.choice(NONFINITE + HUGE + BIGINT[:3] + ("1", True, None))
            if v is None:
                v = [1.0, 2.0]
            base[k] = v
            value = base
            if isinstance(v, int) and not isinstance(v, bool) and v < 2 ** 63 and \
                    rule == "quat":
                expect = "either"
        elif kind == "length":
            value = base[:rng.choice((0, 1, 2))] if rng.random() < 0.5 else base + [0.0] * \
                rng.choice((1, 2, 1000))
        elif kind == "scalar":
            value = 1.0
        elif kind == "wrongtype":
            value = rng.choice(("[1, 2, 3]", {"x": 1.0}, True))
        elif kind == "nested":
            value = [base]
        elif kind == "deep":
            value = _deep_list(rng.choice((3, 100, 5000)), 0.1)
        else:
            value = [0.0] * len(base)
            expect = "refuse" if rule in ("pos", "quat") else "either"
        _set(doc, path, value)
        return Case(index, "scene", f"{fname(path)} = {_short(value)}", doc, expect=expect,
                    fields=fields_for(path), toml_level_ok=kind == "deep")
    if r < 0.70:          # strings
        choices = [("name",), ("body", "shape"), ("run", "method"), ("run", "model"),
                   ("run", "outputs"), ("point", "law")]
        path = rng.choice(choices)
        s = rng.choice(hostile_strings(marker))
        if path == ("run", "outputs"):
            value = [s] if rng.random() < 0.5 else ["pose", s]
            expect = "refuse"
            f = fields_for(path)
        elif path == ("point", "law"):
            k = rng.randrange(3)
            value = list(doc["point"]["law"])
            value[k] = s
            expect = "refuse"
            f = (f"[point].law[{k}]",)
        elif path == ("name",):
            value = s
            expect = "either"
            f = ("name",)
        else:
            value = s
            expect = "refuse"
            f = fields_for(path)
        if rng.random() < 0.1 and path != ("point", "law"):
            value = rng.choice((1.0, True, ["sphere"], {"a": "b"}))
            expect = "refuse"
        _set(doc, path, value)
        return Case(index, "scene", f"{fname(path)} = {_short(value)}", doc, expect=expect,
                    fields=f)
    if r < 0.80:          # missing keys and tables
        paths = [(k,) for k in doc] + [(t, k) for t in doc if isinstance(doc[t], dict)
                                        for k in doc[t]]
        path = rng.choice(paths)
        _del(doc, path)
        return Case(index, "scene", f"without {fname(path)}", doc, expect="either",
                    fields=fields_for(path) + ((f"[{path[0]}]",) if len(path) == 1 else ()))
    if r < 0.90:          # extra keys
        where = rng.choice(("top", "body", "point", "plane", "initial", "run", "newtable",
                            "nested"))
        key = rng.choice(("colour", "rtoll", "Mass", "mass ", "law\x00", "__class__",
                          "shape.x", "k" * 1000, "\u043c\u0430ss"))
        if where == "top":
            doc[key] = 1.0
            f = (key,)
        elif where == "newtable":
            doc[key] = {"x": 1.0}
            f = (key,)
        elif where == "nested":
            doc["body"]["extra"] = _deep_dict(rng.choice((3, 200)))
            key, f = "extra", ("[body].extra", "extra")
            return Case(index, "scene", f"extra key {key!r:.40} in {where}", doc,
                        expect="refuse", fields=f, toml_level_ok=True)
        else:
            doc[where][key] = 1.0
            f = (f"[{where}].{_escaped(key)[:30]}", _escaped(key)[:30])
        if where in ("top", "newtable"):
            f = (_escaped(key)[:30],)
        return Case(index, "scene", f"extra key {key!r:.40} in {where}", doc,
                    expect="refuse", fields=f)
    # several things at once (either; must not crash)
    c1 = scene_mutation(rng, index, marker)
    c2 = scene_mutation(rng, index, marker)
    doc = c1.doc
    for t, v in c2.doc.items():
        if isinstance(v, dict) and isinstance(doc.get(t), dict):
            doc[t].update(v)
    return Case(index, "scene", f"{c1.desc} and {c2.desc}", doc, expect="either",
                fields=None)


def _escaped(key: str) -> str:
    """How a message shows a key: control characters escaped (\\x00), as SceneError
    prints it."""
    return printable(key)


def _short(v) -> str:
    depth = 0
    while isinstance(v, list) and len(v) == 1 and isinstance(v[0], list):
        v, depth = v[0], depth + 1
    if depth > 3:
        return f"a list nested {depth + 1} deep"
    s = repr(v)
    return s if len(s) < 80 else s[:70] + f"...({len(s)} chars)"


def law_case(rng: random.Random, index: int, marker: str) -> Case:
    doc = base_scene()
    k = rng.randrange(3)
    window = (0.0, doc["run"]["duration"])
    r = rng.random()
    laws = {}
    if r < 0.35:
        tree = random_law(rng, depth=rng.choice((1, 2, 3, 4)))
        text, expect, desc = law_text(tree), "either", "random"
        laws[k] = tree
        if rng.random() < 0.3:
            text = text.replace("**", "^")
    elif r < 0.60:
        kind, tree, a, inside = planted_law(rng, window)
        text = law_text(tree)
        expect = "refuse" if inside else "either"
        desc = f"{kind} at t = {a:.6g} ({'inside' if inside else 'outside'} the run)"
        laws[k] = tree
    elif r < 0.90:
        text = rng.choice(HOSTILE_LAWS + EITHER_LAWS).replace("MARKER", marker)
        expect, desc = ("either" if text in EITHER_LAWS else "refuse"), "hostile"
        if rng.random() < 0.3:    # inside a valid expression
            text = f"0.1*sin(t) + {text}"
    else:
        desc, text, expect = rng.choice(deep_laws())
    doc["point"]["law"][k] = text
    return Case(index, "law", f"law[{k}] {desc}: {text}", doc, expect=expect,
                fields=(f"[point].law[{k}]",), laws=laws, window=window)


def table_case(rng: random.Random, index: int, marker: str, outside: str) -> Case:
    """Tabulated laws: a file below the scene's folder, or samples inline."""
    doc = base_scene()
    good = csv_text(table_rows())
    r = rng.random()
    files: dict = {}
    expect, f = "refuse", ("[point].table",)
    point = {"mass": 0.2, "table": "law.csv"}
    if r < 0.45:
        kind = rng.choice((
            "dotdot", "absolute", "absolute-good", "symlink-out", "symlink-dev",
            "dev-zero", "dev-random", "fifo", "dir", "missing", "empty-name", "nul-name",
            "home", "proc", "inside-dotdot", "url", "glob", "backslash", "long-name"))
        if kind == "dotdot":
            point["table"] = "../" * rng.choice((1, 3, 8)) + "outside.csv"
            if point["table"] == "../outside.csv":
                files["../outside.csv"] = good.encode()
        elif kind == "absolute":
            point["table"] = rng.choice(("/etc/passwd", "/etc/hostname", "/"))
        elif kind == "absolute-good":
            point["table"] = outside
        elif kind == "symlink-out":
            files["law.csv"] = ("symlink", outside)
        elif kind == "symlink-dev":
            files["law.csv"] = ("symlink", "/dev/zero")
        elif kind == "dev-zero":
            point["table"] = "/dev/zero"
        elif kind == "dev-random":
            point["table"] = "/dev/urandom"
        elif kind == "fifo":
            files["law.csv"] = ("fifo",)
        elif kind == "dir":
            files["law.csv"] = ("dir",)
        elif kind == "missing":
            point["table"] = "nothere.csv"
        elif kind == "empty-name":
            point["table"] = rng.choice(("", ".", "./"))
        elif kind == "nul-name":
            point["table"] = "law.csv\x00.txt"
        elif kind == "home":
            point["table"] = "~/law.csv"
        elif kind == "proc":
            point["table"] = "/proc/self/environ"
        elif kind == "inside-dotdot":
            files["sub/x"] = b""
            files["law.csv"] = good.encode()
            point["table"] = "sub/../law.csv"
            expect = "either"
        elif kind == "url":
            point["table"] = "http://127.0.0.1:9/law.csv"
        elif kind == "glob":
            point["table"] = "*.csv"
        elif kind == "backslash":
            point["table"] = "..\\outside.csv"
        else:
            point["table"] = "a" * 5000 + ".csv"
        files.setdefault("law.csv", good.encode())
        desc = f"table path {kind}: {point['table']!r:.60}"
    elif r < 0.80:
        kind = rng.choice((
            "huge", "long-line", "ragged", "text", "nan", "inf", "big", "fullwidth",
            "unsorted", "duplicate", "one-row", "empty", "header-only", "binary", "bom",
            "crlf", "extra-col", "no-header", "short-range", "hostile-header", "quoted",
            "spaces", "jumps"))
        rows = table_rows()
        text = None
        expect = "refuse"
        if kind == "huge":
            n = 1_000_000
            t = np.linspace(0, 1, n)
            body = "\n".join(f"{float(a)!r},0.1,0.1,0.1" for a in t[:n])
            text = "t,x,y,z\n" + body + "\n"
            expect = "either"
        elif kind == "long-line":
            text = "t,x,y,z\n" + "1" * 5_000_000 + "\n"
        elif kind == "ragged":
            rows[rng.randrange(1, 100)] = rows[0][:rng.choice((1, 2, 3))]
        elif kind in ("text", "nan", "inf", "big", "fullwidth"):
            rr = rng.randrange(1, 100)
            cc = rng.randrange(4)
            rows[rr][cc] = {"text": "abc", "nan": "nan", "inf": "inf", "big": "1e400",
                            "fullwidth": "\uff10.1"}[kind]
        elif kind == "unsorted":
            rows[10], rows[20] = rows[20], rows[10]
        elif kind == "duplicate":
            rows[11] = list(rows[10])
        elif kind == "one-row":
            rows = rows[:rng.choice((0, 1, 2))]
            expect = "refuse"
        elif kind == "empty":
            text = ""
        elif kind == "header-only":
            text = "t,x,y,z\n"
        elif kind == "binary":
            text = bytes(rng.randrange(256) for _ in range(5000))
        elif kind == "bom":
            text = "\ufeff" + good
            expect = "either"
        elif kind == "crlf":
            text = good.replace("\n", "\r\n")
            expect = "either"
        elif kind == "extra-col":
            text = csv_text([r + [1.0] for r in rows], "t,x,y,z,w")
            expect = "either"
        elif kind == "no-header":
            text = good.split("\n", 1)[1]
        elif kind == "short-range":     # covers half the run
            rows = table_rows(51, 0.5)
            expect = "either"
        elif kind == "hostile-header":
            text = good.replace("t,x,y,z", f"t,x,y,z$(touch {marker})", 1)
        elif kind == "quoted":
            text = good.replace("0.1,", '"0.1",')
            expect = "either"
        elif kind == "spaces":
            text = good.replace(",", ", ")
            expect = "either"
        else:                          # a step in x: not C^2
            rows = [[r[0], r[1] + (0.05 if r[0] > 0.5 else 0.0), r[2], r[3]] for r in rows]
            expect = "either"
        if text is None:
            text = csv_text(rows)
        files["law.csv"] = text if isinstance(text, bytes) else text.encode("utf-8")
        desc = f"table file {kind}"
    else:
        f = ("[point].samples", "[point].ends")
        rows = table_rows()
        kind = rng.choice(("flat", "short-rows", "long-rows", "empty", "one", "strings",
                           "nan", "bools", "nested", "unsorted", "both", "ends-bad",
                           "ends-type", "big", "many", "deep", "ends-periodic",
                           "scalar"))
        expect = "refuse"
        samples: object = rows
        point = {"mass": 0.2, "samples": samples}
        if kind == "flat":
            point["samples"] = [v for r in rows for v in r]
        elif kind == "short-rows":
            point["samples"] = [r[:3] for r in rows]
        elif kind == "long-rows":
            point["samples"] = [r + [0.0] for r in rows]
        elif kind == "empty":
            point["samples"] = []
        elif kind == "one":
            point["samples"] = rows[:1]
        elif kind == "strings":
            rows[5][2] = "0.1"
        elif kind == "nan":
            rows[5][rng.randrange(4)] = rng.choice(NONFINITE)
        elif kind == "bools":
            rows[5][1] = True
        elif kind == "nested":
            rows[5][1] = [0.1]
        elif kind == "unsorted":
            rows[3], rows[4] = rows[4], rows[3]
        elif kind == "both":
            point["law"] = ["0", "0", "0"]
            f = ("[point].samples", "[point].law", "[point]")
        elif kind == "ends-bad":
            point["ends"] = rng.choice(hostile_strings(marker)[:8] + ["Periodic", "loop"])
            f = ("[point].ends",)
        elif kind == "ends-type":
            point["ends"] = rng.choice((1, True, ["rest"]))
            f = ("[point].ends",)
        elif kind == "big":
            rows[7][1] = 1e300
        elif kind == "many":
            point["samples"] = table_rows(100_000)
            expect = "either"
        elif kind == "deep":
            point["samples"] = _deep_list(3000, 0.0)
            doc["point"] = point
            return Case(index, "table", "samples deep", doc, expect=expect, fields=f,
                        toml_level_ok=True)
        elif kind == "ends-periodic":
            point["ends"] = "periodic"
        else:
            point["samples"] = 1.0
        desc = f"samples {kind}"
        doc["point"] = point
        return Case(index, "table", desc, doc, expect=expect, fields=f)
    doc["point"] = point
    return Case(index, "table", desc, doc, files=files, expect=expect, fields=f)


def toml_case(rng: random.Random, index: int) -> Case:
    good = toml.dumps(base_scene())
    kind = rng.choice(("deep-array", "deep-inline", "bad-utf8", "nul", "duplicate",
                       "huge-comment", "dotted-conflict", "bom", "unterminated",
                       "huge-int", "ml-string-law", "control-char"))
    fields = None
    expect = "refuse"
    if kind == "deep-array":
        text = good.replace("inertia = [0.1, 0.12, 0.14]",
                            "inertia = " + "[" * 5000 + "]" * 5000)
    elif kind == "deep-inline":
        text = good + "\n[extra]\nx = " + "{a = " * 3000 + "1" + "}" * 3000 + "\n"
    elif kind == "bad-utf8":
        text = good.encode() + b"\nname2 = \"\xff\xfe\"\n"
    elif kind == "nul":
        text = good.replace('name = "bouncing-ball"', 'name = "a\x00b"')
    elif kind == "duplicate":
        text = good + "\n[body]\nmass = 2.0\n"
    elif kind == "huge-comment":
        text = good + "#" + "x" * 20_000_000 + "\n"
        expect = "either"
    elif kind == "dotted-conflict":
        text = "body.mass = 1.0\n" + good
    elif kind == "bom":
        text = "\ufeff" + good
        expect = "either"
    elif kind == "unterminated":
        text = good[: len(good) // 2]
    elif kind == "huge-int":
        text = good.replace("mass = 1.0", "mass = " + "9" * 5000, 1)   # the reader's
        fields = None                                                  # limit: file named
    elif kind == "ml-string-law":
        text = good.replace('"0.1"', '"""0.1\n*t"""', 1)
        fields = ("[point].law[1]",)
    else:
        text = good.replace('name = "bouncing-ball"', 'name = "a\x07b"')
    return Case(index, "toml", f"TOML {kind}", None, text=text, expect=expect,
                fields=fields)


def generate(n: int, seed: int = 12) -> list[Case]:
    """n cases from the seed, in the proportions scene 45%, law 35%, table 15%, toml 5%."""
    rng = random.Random(seed)
    marker = "MARKER_PWNED"
    cases = []
    for i in range(n):
        r = rng.random()
        if r < 0.45:
            c = scene_mutation(rng, i, marker)
        elif r < 0.80:
            c = law_case(rng, i, marker)
        elif r < 0.95:
            c = table_case(rng, i, marker, outside="OUTSIDE")
        else:
            c = toml_case(rng, i)
        cases.append(c)
    return cases


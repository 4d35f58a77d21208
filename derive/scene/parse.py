"""From a document to a :class:`~derive.scene.scene.Scene`: read every field against
the schema (:mod:`~derive.scene.schema`), apply the rules across fields
(:mod:`~derive.scene.rules`) in two parts — the static part, kept for scenes seen
before (:mod:`~derive.scene.cache`), and the state part — and build the Scene.

A scene is untrusted input.  Nothing in it is executed or pasted into source: laws go
through :mod:`derive.scene.law` (a whitelist parser into a program the C runtime
interprets), tables through :mod:`derive.scene.table`, numbers are checked finite and
in range, and every failure raises :class:`SceneError` naming the field and the rule.
"""
from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path

from . import cache, rules
from .cache import Copy, Snapshot, Static
from .errors import SceneError, type_name
from .rules import Draft
from .scene import Control, Disturbance, Scene, Stability
from .schema import CONTROL_FIELDS, DISTURBANCE_FIELDS, SCENE

MAX_BYTES = 16 * 1024 * 1024
# a table header [point] and an array header [[point]] in one text (TOML refuses them)
_BOTH_POINTS = (re.compile(r"^[ \t]*\[[ \t]*point[ \t]*\]", re.M),
                re.compile(r"^[ \t]*\[\[[ \t]*point[ \t]*\]\]", re.M))


def read_document(source, origin: str = "scene", what: str = "scene") -> tuple[dict, bool]:
    """The dict of a document given as TOML text or as a dict, and whether it is the
    parser's own (a TOML text's: nobody else holds it)."""
    if isinstance(source, str):
        if len(source) > MAX_BYTES:
            raise SceneError(origin, "is larger than 16 MB")
        empty = SceneError(origin, f"is empty: a {what} needs at least [body] and a "
                                   "[point], a [[point]] or a [[rotor]] (`derive scene new` "
                                   "prints one)")
        if _BOTH_POINTS[0].search(source) and _BOTH_POINTS[1].search(source):
            raise SceneError("[point]", "and [[point]] both given: one point is [point], "
                                        "several are a [[point]] each")
        if not source.strip():
            raise empty
        try:
            doc = tomllib.loads(source)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(origin, f"is not valid TOML ({str(exc)[:200]})") from None
        except RecursionError:
            raise SceneError(origin, "is nested too deeply") from None
        except ValueError as exc:       # e.g. an integer of more than 4300 digits
            raise SceneError(origin, f"is not valid TOML ({str(exc)[:120]})") from None
        if not doc:                     # comments and blank lines only
            raise empty
        return doc, True
    if isinstance(source, dict):
        return source, False
    raise SceneError(origin, "must be TOML text, a path or a dict")


def read_file(path, what: str = "scene") -> str:
    """A scene's or a task's text, refused cleanly when it cannot be: a file, or a pipe
    (``<(...)``, ``/dev/stdin``: read up to the size limit)."""
    path = Path(path)
    where = str(path)[:200]
    if path.is_dir():
        raise SceneError(where, f"is a folder, not a {what} file")
    if not path.exists():
        raise SceneError(where, f"no such {what} file")
    try:
        if path.is_file():
            if path.stat().st_size > MAX_BYTES:
                raise SceneError(where, "is larger than 16 MB")
            return path.read_text(encoding="utf-8")
        with open(path, "rb") as f:                  # a pipe: its size is known at the end
            data = f.read(MAX_BYTES + 1)
        if len(data) > MAX_BYTES:
            raise SceneError(where, "is larger than 16 MB")
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(where, f"is not UTF-8 text (byte {exc.start}: a binary file?)") \
            from None
    except OSError as exc:
        raise SceneError(where, f"cannot be read ({type(exc).__name__})") from None


# ---- the two parts -----------------------------------------------------------------------
def static_part(v: dict, given: set, origin: str = "scene", base: Path | None = None,
                with_law: bool = True, point_at: tuple | None = None) -> Static:
    """Every rule across fields that does not read the initial state, and the Scene's
    attributes they give."""
    d = Draft(v, given, origin, base, with_law, point_at)
    rules.check(rules.STATIC_RULES, d)
    return Static(scene_fields(v, d, origin, with_law), d)


def scene_fields(v: dict, d: Draft, origin: str = "scene", with_law: bool = True) -> dict:
    """The Scene's attributes but those of the state, from the field values and the
    static rules' draft (a study's bulk read passes columns through: derive.scene.bulk)."""
    defaults = SCENE.defaults()

    def run(key):
        where = f"[run].{key}"
        return v[where] if where in v else defaults[where]
    st = Stability(run_stability(v, "period"), run_stability(v, "impacts_every"),
                   run_stability(v, "long_periods"), run_stability(v, "perturbations"))
    # m: the point's mass; with other bodies the points' total (a task: [point].mass)
    m = v["[point].mass"] if not with_law else d.points[0].mass if d.one_point else \
        sum(p.mass for p in d.points)
    return dict(name=v["name"], M=v["[body].mass"], J=v["[body].inertia"],
                shape=v["[body].shape"], size=d.size, center=d.center, m=m,
                law=d.law, law_text=d.law_text, plane=d.plane, e=d.e, t0=d.t0,
                friction=d.friction, restitution_model=d.restitution_model,
                spin_friction=d.spin_friction, rolling_resistance=d.rolling_resistance,
                static_friction=d.static_friction, pressure=d.pressure,
                duration=d.duration if with_law else 0.0,
                method=run("method"), rtol=run("rtol"), atol=run("atol"), g=run("g"),
                outputs=run("outputs"), max_events=run("max_events"),
                max_steps=run("max_steps"), output_dt=run("output_dt"),
                keep_orthonormal=run("keep_orthonormal"), model=run("model"),
                zeno_dt=run("zeno_dt"), source=origin, stability=st,
                law_summary=d.summary, max_distance=d.max_distance,
                control=_control(v, d.given), disturbance=_disturbance(v, d.given),
                internal=None if not with_law or d.one_point else (d.points, d.rotors),
                bodies_law=d.bodies,
                given=tuple(sorted(g for g in d.given if not g.startswith("[initial]"))))


def _control(v: dict, given: set) -> Control | None:
    """``[control]``; a field the mode does not read is refused (a key accepted and then
    ignored would say a loop runs that does not)."""
    if "control" not in v["__tables__"]:
        return None
    mode = v["[control].mode"]
    for f in CONTROL_FIELDS:
        if f.modes and f.where in given and mode not in f.modes:
            modes = " or ".join(f'"{m}"' for m in f.modes)
            raise SceneError(f.where, f'is read with mode = {modes} only, not with mode = '
                                      f'"{mode}" (remove it, or change [control].mode)')
    return Control(**{f.key: v[f.where] for f in CONTROL_FIELDS})


# the [disturbance] keys only a closed loop reads, and why: without [control] each is
# refused (derive.control.run applies the pushes of an open run)
CONTROLLER_ONLY = {
    "noise": "is what a controller reads, and without [control] nothing reads it",
    "mass_factor": "scales the plant against the model a controller keeps; without "
                   "[control] there is one body: write it in [body]",
    "point_mass_factor": "scales the plant against the model a controller keeps; without "
                         "[control] there is one body: write it in [point]",
    "inertia_factor": "scales the plant against the model a controller keeps; without "
                      "[control] there is one body: write it in [body]",
    "restitution": "is the plant's against the model a controller keeps; without "
                   "[control] write it in [plane]",
}


def _disturbance(v: dict, given: set) -> Disturbance | None:
    """``[disturbance]``: its pushes act in every run (derive.control.run); the rest only
    where a loop is closed."""
    if "disturbance" not in v["__tables__"]:
        return None
    if "control" not in v["__tables__"]:
        for key, why in CONTROLLER_ONLY.items():
            if f"[disturbance].{key}" in given:
                raise SceneError(f"[disturbance].{key}", why)
    if "[disturbance].seed" in given and "[disturbance].noise" not in given:
        raise SceneError("[disturbance].seed", "seeds the noise, and [disturbance] has no "
                                               "noise table")
    got = {f.key: v[f.where] for f in DISTURBANCE_FIELDS}
    noise = got.pop("noise") or {}
    pushes = got.pop("pushes") or ()
    return Disturbance(**got, noise=tuple(noise.get(k, 0.0) for k in
                                          ("omega", "attitude", "com", "com_velocity")),
                       pushes=tuple((p["time"], *p["impulse"], *p["at"]) for p in pushes))


def run_stability(v: dict, key: str):
    where = f"[stability].{key}"
    return v[where] if where in v else SCENE.defaults()[where]


def state_part(static: Static, v: dict, given: set, source) -> Scene:
    """The rules that read the initial state, and the Scene."""
    d = static.draft.for_state(v, given)
    rules.check(rules.STATE_RULES, d)
    return Scene.of_fields(static.fields, com=d.extra["com"],
                           com_velocity=d.extra["com_velocity"],
                           omega=v["[initial].omega"], A0=d.A0,
                           on_plane=bool(v["[initial].on_plane"]),
                           step=d.extra.get("step", 0.0), doc_source=source)


# ---- scenes ------------------------------------------------------------------------------
def parse_scene(source: str | dict, origin: str = "scene", base: Path | None = None) -> Scene:
    """Validate a scene given as TOML text or as an already-parsed dict; ``base`` is the
    folder a ``[point].table`` path is relative to."""
    return parse(source, origin, base)[0]


def parse(source: str | dict, origin: str = "scene",
          base: Path | None = None) -> tuple[Scene, Static]:
    """parse_scene, and the static part the Scene was made from."""
    doc, owned = read_document(source, origin)
    key = cache.static_key(doc, origin, base)
    seen = cache.lookup(key)
    if seen is not None:
        v, given = dict(seen[0]), set(seen[1])
        SCENE.read_table(doc, cache.STATE_TABLE, v, given)
        return state_part(seen[2], v, given, Snapshot(key, doc, v, given)), seen[2]
    v, given = SCENE.read(doc)
    static = static_part(v, given, origin, base)
    if key is not None and cache.remember(key, doc, v, given, static):
        kept = Snapshot(key, doc, v, given)
    else:
        kept = Copy(doc, owned=owned)
    return state_part(static, v, given, kept), static


def build_scene(v: dict, given: set, doc, origin: str = "scene",
                base: Path | None = None) -> Scene:
    """A Scene from field values already read (``SCENE.read`` and overrides); ``doc``:
    the scene's dict (copied) or an object whose ``get()`` gives it (:attr:`Scene.doc`)."""
    source = Copy(doc) if isinstance(doc, dict) else doc
    return state_part(static_part(v, given, origin, base), v, given, source)


def build_body(v: dict, given: set, point_at: tuple, origin: str = "scene") -> Scene:
    """A Scene without a law (a planning task's: the planner makes the law), from field
    values read by a schema without the law's fields; the point is at ``point_at`` (body
    axes) at the start."""
    static = static_part(v, given, origin, None, with_law=False, point_at=tuple(point_at))
    return state_part(static, v, given, None)


def load_scene(scene) -> Scene:
    """A :class:`Scene` from a path, a dict or a Scene."""
    return load(scene)[0]


def load(scene) -> tuple[Scene, Static | None]:
    """load_scene, and the static part the Scene was made from (None for a Scene given)."""
    if isinstance(scene, Scene):
        return scene, None
    if isinstance(scene, dict):
        return parse(scene, "scene", None)
    if not isinstance(scene, (str, os.PathLike)):
        raise SceneError("scene", f"must be a path, a dict of the schema or a Scene, not "
                                  f"{type_name(scene)}")
    path = Path(scene)
    return parse(read_file(path), str(path), path.parent)

"""What the schema gives besides validation: the README's tables (a test keeps the README
equal to them), the commented template of ``derive scene new`` and the built-in scene."""
from __future__ import annotations

from .. import shapes
from . import rules
from . import toml
from .schema import (ARRAYS, CONTROL_FIELDS, DISTURBANCE_FIELDS, PLAN_FIELDS, REQUIRED,
                     SCENE_FIELDS, SCENE_TABLES)


def _arrays_note() -> str:
    """How the internal bodies are given (the arrays of tables)."""
    return (f"Internal bodies: `[point]` is one point; `[[point]]`, once per point (0 to "
            f"{ARRAYS['point']}), gives several, each with the fields of `[point]`; "
            f"`[[rotor]]`, once per rotor (0 to {ARRAYS['rotor']}). Messages name the "
            "element: `[[rotor]] 2: axis: must be a unit vector`. A scene of anything but "
            "one point and no rotor runs in a moments model (`moments`, `moments_rough`).")


def _default(f) -> str:
    if f.default is REQUIRED:
        return "required"
    if f.default is None:
        return "—"
    return f"`{toml.value(f.default)}`"


def _modes(f) -> str:
    """A [control] field's modes, as the table and the template say them."""
    if not f.modes:
        return ""
    names = " or ".join(f'"{m}"' for m in f.modes)
    return f" (read with mode = {names} only; refused with another)"


def _rows(fields) -> list:
    rows = ["| field | type | default | rule | meaning |", "|---|---|---|---|---|"]
    for f in fields:
        kind = f"{f.kind}[{f.size}]" if f.size else f.kind
        doc = f.doc + (f" ({f.when})" if f.when else "") + _modes(f)
        rows.append(f"| `{f.where}` | {kind} | {_default(f)} | {f.rule} | {doc} |")
        for s in f.fields:
            kind = f"{s.kind}[{s.size}]" if s.size else s.kind
            where = s.where.replace(f"{f.key}.", f"{f.key}[].") if f.kind == "tables" \
                else s.where
            rows.append(f"| `{where}` | {kind} | {_default(s)} | {s.rule} | {s.doc} |")
    return rows


def schema_table() -> str:
    """The README's scene schema: every field, then the rules across fields."""
    rows = _rows(SCENE_FIELDS + CONTROL_FIELDS + DISTURBANCE_FIELDS)
    rows += ["", _arrays_note()]
    rows += ["", "Rules across fields:", ""]
    rows += [f"- {text}" for text in rules.texts()]
    return "\n".join(rows)


def plan_table() -> str:
    """The README's ``[plan]`` schema."""
    return "\n".join(_rows(PLAN_FIELDS))


def template(shape: str = "sphere") -> str:
    """A commented scene of every field (``derive scene new``)."""
    lines = ["# A scene for `derive simulate` (every key; defaults where not required).",
             "# Schema: README.md, section 'Scene schema'."]
    table = None
    mine = {s.key for s in shapes.of(shape).sizes} if shape in shapes.SHAPES else set()
    skip = {size.key for size, _ in shapes.size_fields()} - mine   # others' sizes
    for f in SCENE_FIELDS:
        if f.table in ("stability", "control", "disturbance") or \
                (f.table == "body" and f.key in skip):
            continue
        if f.table == "rotor":            # none by default: the fields commented out
            if table != "rotor":
                table = "rotor"
                lines += ["", f"# [[rotor]]  # zero or more: one [[rotor]] per rotor, at most "
                              f"{ARRAYS['rotor']} (several points: one [[point]] each, at "
                              f"most {ARRAYS['point']})"]
            note = f.doc + (f"; {f.rule}" if f.rule else "")
            lines.append(f"# {f.key} = {toml.value(f.example)}  # {note}")
            continue
        if f.table != table:
            table = f.table
            lines.append("")
            if f.table:
                lines.append(f"[{f.table}]")
        value = f.example if f.example is not None else (
            None if f.default is None or f.default is REQUIRED else f.default)
        if f.key == "shape":
            value = shape
        note = (f.doc + (f"; {f.rule}" if f.rule else "") + (f" ({f.when})" if f.when else "")
                + _modes(f))
        if value is None or f.key in ("table", "samples", "matrix", "ends"):
            lines.append(f"# {f.key} = ...{' ' * 20}# {note}")
        elif f.models:
            # read by some models only, and this scene (in flight) runs another: given
            # here it would be refused, so it is shown commented out
            lines.append(f"# {f.key} = {toml.value(value)}  # {note}")
        else:
            lines.append(f"{f.key} = {toml.value(value)}  # {note}")
    lines.append("")
    lines.append("# [stability] (optional): period, impacts_every, long_periods, perturbations")
    lines.append("# [control] and [disturbance] (optional): the loop closed around the run")
    return "\n".join(lines) + "\n"


def builtin_doc() -> dict:
    """The built-in scene: a ball whose internal point moves, bouncing on the plane."""
    return {
        "name": "bouncing-ball",
        "body": {"mass": 1.0, "inertia": [0.10, 0.12, 0.14], "shape": "sphere", "radius": 0.5,
                 "center": [0.0, 0.0, 0.0]},
        "point": {"mass": 0.2, "law": ["0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"]},
        "plane": {"restitution": 0.9},
        "initial": {"time": 0.0, "com": [0.0, 0.0, 1.5], "com_velocity": [0.3, 0.0, 0.0],
                    "omega": [0.5, -0.3, 1.0], "quaternion": [1.0, 0.0, 0.0, 0.0]},
        "run": {"duration": 5.0, "method": "lie", "rtol": 1e-10, "atol": 1e-12, "g": 9.81,
                "outputs": ["pose", "impacts"]},
    }


def _builtin_toml() -> str:
    doc = builtin_doc()
    ordered = {k: doc[k] for k in ("name", *SCENE_TABLES[1:]) if k in doc}
    return toml.dumps(ordered, ("The built-in scene: a ball whose internal point moves, "
                                "bouncing on the plane.",))


DEFAULT_SCENE = _builtin_toml()

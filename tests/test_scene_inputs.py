"""What a scene's input handling owes the user beyond the range of each value: a key the
run would not read is refused, not accepted and then ignored, and every message echoes
what was typed (issue 34, items 4 and 5)."""
from __future__ import annotations

import copy
import tomllib

import pytest

from derive.paths import ROOT
from derive.scene import SceneError, parse_scene
from derive.scene.schema import CONTROL_FIELDS

_MODES = ("hop", "mirror", "replan")
_EXAMPLE = {"hop": "hop.toml", "mirror": "mirror.toml", "replan": "land_push.toml"}
_VALUE = {"number": 0.5, "integer": 8, "choice": None}


def _example(mode: str) -> dict:
    path = ROOT / "derive" / "control" / "examples" / _EXAMPLE[mode]
    if not path.exists():                       # an installed wheel keeps them inside
        from importlib import resources
        path = resources.files("derive.control") / "examples" / _EXAMPLE[mode]
    return tomllib.loads(path.read_text(encoding="utf-8"))


def _a_value(f):
    return f.choices[-1] if f.kind == "choice" else _VALUE[f.kind]


def _read(doc: dict):
    """The scene or task of ``doc`` read as derive control and derive simulate read it."""
    from derive.planner.task import load_task
    return load_task(doc) if "plan" in doc else parse_scene(doc)


@pytest.mark.parametrize("f", [f for f in CONTROL_FIELDS if f.modes], ids=lambda f: f.key)
def test_a_control_field_of_another_mode_is_refused_naming_both(f):
    """Every [control] field a mode does not read is refused with that mode, and read
    with the modes the schema names (the same field, the same value: the mode decides)."""
    for mode in _MODES:
        doc = copy.deepcopy(_example(mode))
        doc["control"][f.key] = _a_value(f)
        if mode in f.modes:
            _read(doc)                              # accepted
            continue
        with pytest.raises(SceneError) as err:
            _read(doc)
        text = str(err.value)
        assert text.startswith(f"{f.where}: ") and f'mode = "{mode}"' in text, text
        assert all(f'"{m}"' in text for m in f.modes), text


def test_the_trial_case_deadbeat_with_replan_exits_2(tmp_path):
    import subprocess
    import sys
    doc = _example("replan")
    doc["control"]["gain"] = "deadbeat"
    from derive.scene import toml
    path = tmp_path / "task.toml"
    path.write_text(toml.dumps(doc), encoding="utf-8")
    out = subprocess.run([sys.executable, "-m", "derive", "control", str(path), "-o",
                          str(tmp_path / "out")], capture_output=True, text=True)
    assert out.returncode == 2, out.stderr
    assert out.stderr.count("\n") == 1 and "Traceback" not in out.stderr
    assert '[control].gain: is read with mode = "hop" only, not with mode = "replan"' \
        in out.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("table, key, typed, shown", [
    ("disturbance", "seed", -1, "got -1)"),
    ("disturbance", "seed", 2.5, "got 2.5)"),
    ("body", "mass", -2, "got -2)"),
    ("body", "mass", -2.0, "got -2.0)"),
    ("run", "max_events", 0, "got 0)"),
])
def test_messages_echo_numbers_as_typed(table, key, typed, shown):
    """An integer is echoed as the integer typed (-1, not -1.0); a float as the float."""
    from derive.scene import builtin_doc
    doc = builtin_doc()
    doc.setdefault(table, {})[key] = typed
    with pytest.raises(SceneError) as err:
        parse_scene(doc)
    assert str(err.value).startswith(f"[{table}].{key}: ") and str(err.value).endswith(shown), \
        str(err.value)

"""Scenes: every rule names its field, the CLI exits 2 without a traceback and writes
nothing; laws are parsed by a whitelist; model selection says which and why."""
from __future__ import annotations

import math
import subprocess
import sys
import tomllib

import pytest

from derive.runtime.choice import choose
from derive.scene.law import LawError, parse_law
import derive
from derive.scene import DEFAULT_SCENE, SceneError, load_scene, parse_scene


def doc(**changes):
    d = tomllib.loads(DEFAULT_SCENE)
    for path, value in changes.items():
        section, _, key = path.partition("__")
        if key:
            if value is None:
                d[section].pop(key, None)
            else:
                d.setdefault(section, {})[key] = value
        elif value is None:
            d.pop(section, None)
        else:
            d[section] = value
    return d


BAD = [
    ({"body__colour": "red"}, "[body].colour", "not a known key"),
    ({"wheels": 3}, "wheels", "not a known key"),
    ({"body__mass": "1"}, "[body].mass", "must be a number"),
    ({"body__mass": float("nan")}, "[body].mass", "finite"),
    ({"body__mass": float("inf")}, "[body].mass", "finite"),
    ({"body__mass": 0.0}, "[body].mass", "> 0"),
    ({"point__mass": -0.1}, "[point].mass", "> 0"),
    ({"body__inertia": [0.1, 0.1, 0.3]}, "[body].inertia[2]", "exceeds the sum"),
    ({"body__inertia": [0.1, 0.0, 0.1]}, "[body].inertia[1]", "> 0"),
    ({"body__inertia": [0.1, 0.1]}, "[body].inertia", "list of 3"),
    ({"plane__restitution": 1.5}, "[plane].restitution", "[0, 1]"),
    ({"plane__restitution": -0.1}, "[plane].restitution", "[0, 1]"),
    ({"point__law": ["0.2*sin(3*t)", "__import__('os')", "0"]}, "[point].law[1]", "unexpected"),
    ({"point__law": ["exec(t)", "0", "0"]}, "[point].law[0]", "unknown name"),
    ({"point__law": ["sin(3*t", "0", "0"]}, "[point].law[0]", "expected ')'"),
    ({"point__law": ["0", "0"]}, "[point].law", "three strings"),
    ({"point__law": ["sqrt(t)", "0", "0"]}, "[point].law[0]", "not twice differentiable"),
    ({"point__law": ["log(t - 1)", "0", "0"]}, "[point].law[0]", "not twice differentiable"),
    ({"initial__com": [0.0, 0.0, 0.2]}, "[initial].com", "below the plane"),
    # a NaN or infinity inside a vector of floats (min and max do not see a NaN there)
    ({"initial__com": [0.0, float("nan"), 1.5]}, "[initial].com[1]", "finite"),
    ({"initial__omega": [0.5, float("inf"), -float("inf")]}, "[initial].omega[1]", "finite"),
    ({"body__center": [0.0, 0.0, float("nan")]}, "[body].center[2]", "finite"),
    ({"initial__quaternion": [0.0, 0.0, 0.0, 0.0]}, "[initial].quaternion", "zero norm"),
    ({"initial__matrix": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}, "[initial].quaternion",
     "either quaternion or matrix"),
    ({"body__shape": "cube"}, "[body].shape", "one of"),
    ({"body__radius": -1.0}, "[body].radius", "> 0"),
    ({"run__method": "euler"}, "[run].method", "one of"),
    ({"run__outputs": ["pose", "colour"]}, "[run].outputs", "not one of"),
    ({"run__duration": -5.0}, "[run].duration", "> 0"),
    ({"run__rtol": 0.0}, "[run].rtol", "in [1e-15, 0.01]"),
    ({"plane": {}}, "[plane].restitution", "required"),
    ({"body__inertia": [1e-13, 0.5, 0.5], "point__law": ["0", "0", "0"]}, "[body].inertia",
     "singular"),
    # with the plane a step is at most the law's time scale: a run that can only end at
    # max_steps, after minutes, is refused before it starts
    ({"point__law": ["0.1*sin(1e8*t)", "0.1", "0"]}, "[point].law", "beyond [run].max_steps"),
    ({"run__duration": 100.0, "run__max_steps": 50}, "[point].law", "shorten [run].duration"),
]


@pytest.mark.parametrize("changes,where,rule", BAD, ids=[b[1] + ":" + b[2] for b in BAD])
def test_bad_scene_names_the_field_and_the_rule(changes, where, rule):
    with pytest.raises(SceneError) as info:
        parse_scene(doc(**changes))
    assert info.value.where == where, str(info.value)
    assert rule in info.value.rule, str(info.value)


def test_matrix_must_be_a_rotation():
    d = doc()
    d["initial"].pop("quaternion")
    d["initial"]["matrix"] = [[1, 0, 0], [0, 1, 0], [0, 0, -1]]
    with pytest.raises(SceneError, match="reflection"):
        parse_scene(d)


def test_cli_bad_scene_exit_2_no_traceback_nothing_written(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text(DEFAULT_SCENE.replace("mass = 1.0", "mass = -1.0"))
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", str(scene), "-o",
                           str(out)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2
    assert "[body].mass: must be > 0" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not out.exists()


def test_cli_missing_and_malformed_files(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate",
                           str(tmp_path / "nope.toml")], capture_output=True, text=True)
    assert proc.returncode == 2 and "no such scene file" in proc.stderr
    bad = tmp_path / "bad.toml"
    bad.write_text("[body\nmass = 1")
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "not valid TOML" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_scene_read_from_a_pipe_and_a_folder_refused(tmp_path):
    """derive scene check <(...) and /dev/stdin read the pipe (it is not a regular file);
    a folder is refused as one, not as a missing file."""
    proc = subprocess.run([sys.executable, "-m", "derive", "scene", "check", "/dev/stdin"],
                          input=DEFAULT_SCENE, capture_output=True, text=True)
    assert proc.returncode == 0 and "valid" in proc.stdout, proc.stderr
    proc = subprocess.run([sys.executable, "-m", "derive", "scene", "check", str(tmp_path)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "is a folder, not a scene file" in proc.stderr


def test_cli_default_scene_writes_everything(tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "derive", "simulate", "-o", str(out), "-q"],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    for name in ("trajectory.csv", "events.csv", "impacts.csv", "summary.json",
                 "overview.png", "motion.gif"):
        assert (out / name).is_file(), name
    header = (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert header[:4] == ["t", "X_C", "Y_C", "Z_C"] and header[-1] == "h"
    import json
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "done" and summary["model"] == "general"
    assert summary["counts"]["impacts"] == 8
    assert summary["invariants"]["K_norm_relative_drift_between_events"] < 1e-9


def test_law_parser_builds_the_expected_expressions():
    import sympy as sp
    t = sp.Symbol("t", real=True)
    cases = {"0.2*sin(3*t)": 0.2 * sp.sin(3 * t), "-2^2": -4, "2**-1": sp.Rational(1, 2),
             "(1+t)/(2-t)": (1 + t) / (2 - t), "1e-3*cos(2*pi*t)": 0.001 * sp.cos(2 * sp.pi * t)}
    for text, expected in cases.items():
        program = parse_law(text)
        want = sp.lambdify(t, [expected, sp.diff(expected, t), sp.diff(expected, t, 2)])
        for tv in (0.0, 0.3, 1.7):
            got = program.jets([tv])[:3, 0]
            ref = want(tv)
            for g, w in zip(got, ref):
                assert abs(g - w) <= 1e-14 * (1 + abs(w)), text
    for text in ("t.__class__", "lambda: 0", "[t]", "t if t else 0", "os", "sin", "1e309",
                 "a" * 3000):
        with pytest.raises(LawError):
            parse_law(text)


def test_model_selection_and_reasons():
    assert choose(parse_scene(doc()))[0] == "general"
    d = doc(run__outputs=["omega", "height", "impacts"])
    kind, why = choose(parse_scene(d))
    assert kind == "vertical" and "pose is not asked" in why
    d = doc(plane=None, run__outputs=["omega"])
    assert choose(parse_scene(d))[0] == "attitude"
    d = doc(initial__omega=[0.0, 0.0, 0.0], point__law=["0", "0", "0.1*sin(t)"])
    kind, why = choose(parse_scene(d))
    assert kind == "translational" and "C2.4" in why
    # the same but the point off the vertical through O: d != 0 at impacts
    d = doc(initial__omega=[0.0, 0.0, 0.0], point__law=["0.1", "0", "0.1*sin(t)"])
    assert choose(parse_scene(d))[0] == "general"
    s = math.sqrt(0.5)
    d = doc(point__law=["0.2*cos(t)", "0.1", "0"], initial__omega=[0.0, 0.0, 1.0],
            initial__quaternion=[s, s, 0.0, 0.0])
    assert choose(parse_scene(d))[0] == "planar"
    d = doc(plane=None, body__inertia=[0.1, 0.1, 0.15], point__law=["0", "0", "0.1*t"])
    assert choose(parse_scene(d))[0] == "axisymmetric"
    d = doc(run__model="vertical")          # forced, but the pose is asked
    with pytest.raises(SceneError, match=r"\[run\].model"):
        choose(parse_scene(d))


# ---- scenes seen before: the static part kept, [initial] re-validated ----------------------
def _outcome(source) -> tuple:
    """What parse_scene makes of a scene: the refusal's text, or every field of the Scene
    (its objects by value: the attitude as a list, the law by its text)."""
    import dataclasses
    try:
        sc = parse_scene(source)
    except SceneError as exc:
        return ("refused", str(exc))
    out = []
    for f in dataclasses.fields(sc):
        value = getattr(sc, f.name)
        if f.name in ("law", "law_summary", "doc_source"):
            continue
        out.append((f.name, value.tolist() if f.name == "A0" else repr(value)))
    return ("scene", tuple(out))


def _static_variants(rng, n: int) -> list:
    """Valid scenes but their [initial] tables: masses, inertia, shapes, laws, runs."""
    out = []
    for k in range(n):
        d = doc(initial=None)
        d["body"]["mass"] = float(rng.uniform(0.5, 3.0))
        j = sorted(rng.uniform(0.1, 0.2, 3))          # each at most the sum of the others
        d["body"]["inertia"] = [float(x) for x in j]
        if k % 3 == 1:
            d["body"].pop("radius")
            d["body"].update(shape="ellipsoid", semi_axes=[0.5, 0.4, 0.3],
                             center=[0.05, -0.02, 0.01])
        if k % 4 == 2:
            d.pop("plane")
        d["point"]["law"] = [f"{rng.uniform(0.05, 0.2):.3f}*sin({rng.integers(1, 4)}*t)",
                             "0.1", f"0.05*cos({rng.integers(1, 4)}*t)"]
        d["run"]["method"] = str(rng.choice(["lie", "dop853", "rk4"]))
        out.append(d)
    return out


def _initial_table(rng):
    """A random [initial] table: valid, or hostile in one of many ways."""
    init = {"time": 0.0, "com": [0.0, 0.0, float(rng.uniform(0.6, 3.0))],
            "com_velocity": [float(x) for x in rng.normal(0, 1, 3)],
            "omega": [float(x) for x in rng.normal(0, 2, 3)],
            "quaternion": [float(x) for x in rng.normal(0, 1, 4)]}
    kind = int(rng.integers(0, 16))
    key = str(rng.choice(["time", "com", "com_velocity", "omega", "quaternion"]))
    bad_values = [math.nan, math.inf, -math.inf, "1.0", True, None, [1.0], {"a": 1.0},
                  10 ** 400, 2 ** 60, 1e300, -1e300]
    if kind == 1:                                    # one entry of a vector, or the time
        v = bad_values[int(rng.integers(len(bad_values)))]
        if key == "time":
            init["time"] = v
        else:
            init[key][int(rng.integers(len(init[key])))] = v
    elif kind == 2:                                  # a vector's length or type
        init[key] = [[], [0.0], init[key] * 2, "abc", 1.0, (1.0, 2.0, 3.0)][int(rng.integers(6))]
    elif kind == 3:
        init["colour"] = 1.0                         # an unknown key
    elif kind == 4:
        init.pop(key)                                # a missing key: its default
    elif kind == 5:
        init["com"][2] = -5.0                        # S below the plane
    elif kind == 6:
        init["quaternion"] = [0.0, 0.0, 0.0, 0.0]
    elif kind == 7:
        init["matrix"] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]   # and quaternion
    elif kind == 8:
        init.pop("quaternion")
        init["matrix"] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    elif kind == 9:
        init["time"] = float(rng.uniform(-10, 10))   # another start time: another law check
    elif kind == 10:
        init["com"] = [1, 2, 3]                      # integers are numbers
    elif kind == 11:
        init["omega"] = [0.0, 0.0, 0.0]              # the model choice changes
    elif kind == 12:
        return [1.0, 2.0]                            # not a table
    elif kind == 13:
        return {}
    return init


def test_a_scene_seen_before_is_validated_as_a_new_one():
    """3000 random scenes, valid and hostile in [initial]: parse_scene gives the same Scene
    or the same refusal whether its static part was kept from an earlier scene (only
    [initial] re-validated) or not; and what it keeps is only plain data."""
    import numpy as np

    from derive.scene import cache
    rng = np.random.default_rng(2026)
    statics = _static_variants(rng, 24)
    hits = 0
    for _ in range(3000):
        static = statics[int(rng.integers(len(statics)))]
        case = {**static, "initial": _initial_table(rng)}
        cache._SEEN.clear()
        cold = _outcome(case)
        cache._SEEN.clear()
        primer = {**static, "initial": {"com": [0.0, 0.0, 2.5]}}
        if isinstance(case["initial"], dict) and "time" in case["initial"]:
            primer["initial"]["time"] = case["initial"]["time"]   # the time is static
        if _outcome(primer)[0] != "scene":
            continue                                # a start time no law check admits
        before = len(cache._SEEN)
        warm = _outcome(case)
        hits += len(cache._SEEN) == before and before == 1
        assert warm == cold, (case["initial"], cold[1] if cold[0] == "refused" else "",
                              warm[1] if warm[0] == "refused" else "")
    assert hits > 2000, hits                        # the kept part served most of them


def test_only_plain_scenes_are_kept_and_types_are_told_apart():
    import numpy as np

    from derive.scene import cache
    cache._SEEN.clear()
    d = doc()
    d["body"]["mass"] = np.float64(1.0)           # accepted, but marshalled as bytes
    parse_scene(d)
    assert len(cache._SEEN) == 0
    d = doc()
    parse_scene(d)
    assert len(cache._SEEN) == 1
    d["body"]["mass"] = True                       # equal to 1.0, not a number here
    with pytest.raises(SceneError, match=r"\[body\].mass: must be a number"):
        parse_scene(d)
    d["body"]["mass"] = 1                          # an integer: another key, accepted
    parse_scene(d)
    assert len(cache._SEEN) == 2


def test_a_scenes_dict_is_the_one_it_was_parsed_from():
    """Scene.doc is a copy of the dict as parsed, whichever path kept it (a scene seen
    before, a first one, a NumPy number in it, TOML text): editing the dict given, or the
    copy read, changes no Scene, and the copy parses back to the same Scene."""
    import copy

    import numpy as np

    from derive.scene import cache
    cache._SEEN.clear()
    for kind in ("first", "seen", "numpy", "toml"):
        d = doc()
        if kind == "numpy":
            d["body"]["mass"] = np.float64(1.0)
        source = DEFAULT_SCENE if kind == "toml" else d
        sc = parse_scene(source)
        assert parse_scene(sc.doc) == sc, kind
        before = copy.deepcopy(sc.doc)
        d["initial"]["com"][2] = 9.0               # the caller edits its dict in place
        d["plane"]["restitution"] = 0.1
        d["initial"]["omega"] = [1.0, 2.0, 3.0]
        got = sc.doc
        assert got == before, kind
        got["body"]["mass"] = 7.0                  # and the copy it read
        assert sc.doc == before and parse_scene(sc.doc) == sc, kind


def test_numpy_numbers_tuples_and_arrays_are_taken_as_their_values():
    """From Python a scene may hold NumPy numbers (np.int64 from np.arange, np.float32),
    tuples and 1-D arrays where the schema has numbers and lists: taken by value (they
    had been refused as 'not int64', 'not a list'); booleans, NumPy's too, are not
    numbers; a scene that is no path, dict or Scene is refused naming the rule."""
    import numpy as np
    d = doc()
    d["body"]["mass"] = np.int64(2)
    d["point"]["mass"] = np.float32(0.25)
    d["initial"]["com"] = (0.0, 0.0, 1.5)
    d["initial"]["omega"] = np.array([0.1, 0.2, 0.3])
    d["point"]["law"] = ("0.1*sin(t)", "0", "0")
    d["run"]["outputs"] = ("pose", "impacts")
    sc = parse_scene(d)
    assert (sc.M, sc.m, sc.com, sc.omega) == (2.0, 0.25, (0.0, 0.0, 1.5), (0.1, 0.2, 0.3))
    assert sc.outputs == ("pose", "impacts") and sc.law_text[0] == "0.1*sin(t)"
    assert parse_scene(sc.doc) == sc
    for bad in (np.bool_(True), True, np.array([1.0])):
        d["body"]["mass"] = bad
        with pytest.raises(SceneError, match=r"\[body\]\.mass: must be a number"):
            parse_scene(d)
    from derive.scene import load_scene
    for bad in (None, 42, [1.0]):
        with pytest.raises(SceneError, match="scene: must be a path, a dict"):
            load_scene(bad)


def test_prepare_keeps_only_what_reads_the_static_part():
    """driver.prepare keeps a scene's options and parameters with its static part: over
    random scenes and initial states (RK4's default step follows omega; the planar model
    adds constants of the initial state) they equal those computed afresh, and they are
    read-only."""
    import numpy as np

    from derive.runtime import choice, driver
    rng = np.random.default_rng(4)
    statics = _static_variants(rng, 12)
    planar = doc(point__law=["0.2*cos(t)", "0.1", "0"])
    planar["initial"]["quaternion"] = [math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0]
    checked = 0
    for k in range(600):
        base = planar if k % 5 == 0 else statics[int(rng.integers(len(statics)))]
        init = dict(base.get("initial", {}))
        init["com"] = [0.0, 0.0, float(rng.uniform(1.0, 3.0))]
        init["omega"] = [0.0, 0.0, float(rng.uniform(0.5, 3.0))] if k % 5 == 0 else \
            [float(x) for x in rng.normal(0, 2, 3)]
        prep = driver.prepare({**base, "initial": init})
        assert np.array_equal(prep.options, driver.options(prep.scene, prep.kind))
        assert np.array_equal(prep.parameters,
                              choice.parameters(prep.scene, prep.start.constants))
        assert not prep.options.flags.writeable and not prep.parameters.flags.writeable
        checked += prep.kind == "planar"
    assert checked > 50


# ---- messages name places one way, and suggest the nearest field (new-user trial) ----------
@pytest.mark.parametrize("law, t", [("1/sin(t)", "0"), ("0.001/(t - 1)", "1"),
                                    ("1/(t - 0.3)", "0.3"), ("sqrt(2.2 - t)", "2.2")])
def test_a_singular_law_is_named_at_its_point(law, t):
    """The singular point is the number of fewest digits in the last box of the proof:
    1/sin(t) had been reported near t = 4.54747351e-12."""
    d = doc()
    d["point"]["law"] = [law, "0", "0"]
    d["run"]["duration"] = 3.0
    with pytest.raises(SceneError) as info:
        parse_scene(d)
    assert info.value.rule.endswith(f"near t = {t}"), str(info.value)


def test_unknown_keys_are_named_in_the_table_form_with_the_nearest_one():
    d = doc()
    d["plain"] = {"restitution": 0.5}
    with pytest.raises(SceneError) as info:
        parse_scene(d)
    assert str(info.value) == "[plain]: is not a known key; did you mean 'plane'?"
    d = doc()
    d["body"]["mas"] = 1.0
    with pytest.raises(SceneError) as info:
        parse_scene(d)
    assert str(info.value) == "[body].mas: is not a known key; did you mean 'mass'?"
    d = doc()
    d["body"]["colour"] = "red"                # nothing near: the table's keys, not all 57
    with pytest.raises(SceneError) as info:
        parse_scene(d)
    assert "known: mass, inertia" in info.value.rule and "[run]" not in info.value.rule


@pytest.mark.parametrize("text", ["\n  \n", "# my scene, to be written\n\n# [body]\n"])
def test_an_empty_file_says_so(tmp_path, text):
    """Blank, or comments only (a second trial's file said only `[body]: is required`)."""
    path = tmp_path / "empty.toml"
    path.write_text(text)
    with pytest.raises(SceneError, match="is empty: a scene needs at least"):
        load_scene(path)


def test_overrides_name_fields_in_the_table_form_and_suggest_the_nearest():
    from derive.scene import overrides
    with pytest.raises(SceneError) as info:
        overrides.parse_assignment("body.mas=1")
    assert "did you mean 'body.mass'?" in str(info.value)
    assert "inertia" not in str(info.value)                # not every field on one line
    with pytest.raises(SceneError) as info:
        overrides.apply_to_doc(doc(), "initial.com[5]", 1.0)
    assert info.value.where == "[initial].com[5]"
    with pytest.raises(SceneError) as info:
        derive.simulate_many(doc(), [{"initial.omaga": [0.0, 0.0, 1.0]}])
    assert "did you mean 'initial.omega'?" in str(info.value)
    assert str(info.value).startswith("variant 1: ")        # which variant (from 1), of many


def test_a_task_given_as_a_scene_is_pointed_to_the_planner():
    """`derive simulate land.toml` (a task) had answered "[plan]: is not a known key; did
    you mean 'plane'?"."""
    import tomllib
    from importlib import resources
    doc = tomllib.loads((resources.files("derive.planner") / "examples" / "land.toml")
                        .read_text())
    with pytest.raises(SceneError) as info:
        parse_scene(doc)
    assert info.value.where == "[plan]" and "derive plan" in info.value.rule
    assert "did you mean" not in str(info.value)

"""Scenes with several internal bodies (issue 32): ``[[point]]`` and ``[[rotor]]``.

Each rule of the schema refuses its case naming the element and the field; the TOML
writer's arrays of tables read back to the same document; the law of many outputs (one
program, one spline) agrees in C, in NumPy and with SymPy's own differentiation of the
same expressions; one point given as ``[[point]]`` runs bit for bit as ``[point]``; and
thousands of random multi-body documents, well-formed and not, are accepted or refused
with the element and field named, none crashing (a sample through the sandboxed fuzz
worker and through ``derive simulate``: exit 2, one line).
"""
from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest
import sympy as sp

from cases import random_law
from derive import abi, layout
from derive.runtime.build import library
from derive.runtime.driver import Session, simulate
from derive.scene import SceneError, builtin_doc, parse_scene
from derive.scene.law import compile_law
from derive.scene.law.bodies import combine
from derive.scene.law.parse import compile_angle
from derive.scene.toml import dumps
from derive.verify import fuzz
from derive.verify.generators import Case

S = abi.STATUS


def _doc(n_points=2, n_rotors=1, duration=2.0) -> dict:
    """The built-in scene with ``n_points`` points (law ``k``-th harmonics) and
    ``n_rotors`` rotors."""
    doc = builtin_doc()
    doc["run"]["duration"] = duration
    doc["point"] = [{"mass": 0.05 * (j + 1),
                     "law": [f"0.1*sin({j + 2}*t)", f"0.05*cos({j + 1}*t)", "0.02*t"]}
                    for j in range(n_points)]
    if n_rotors:
        doc["rotor"] = [{"axis": [0.0, 0.0, 1.0] if r % 2 == 0 else [0.6, 0.8, 0.0],
                         "inertia": 0.01 * (r + 1), "law": f"{10 * (r + 1)}*t + sin(t)"}
                        for r in range(n_rotors)]
    return doc


def _refusal(doc) -> str:
    with pytest.raises(SceneError) as info:
        parse_scene(doc)
    return str(info.value)


def _set(path, value):
    def change(doc):
        holder = doc
        for key in path[:-1]:
            holder = holder[key]
        if value is _DELETE:
            del holder[path[-1]]
        else:
            holder[path[-1]] = value
    return change


_DELETE = object()
_TS = [[0.0, 0.0, 0.0, 0.0], [1.0, 0.1, 0.0, 0.0], [2.0, 0.0, 0.1, 0.0], [3.0, 0.0, 0.0, 0.0]]

# every rule of the new tables: the change, and the message's start
RULES = [
    (_set(("point", 1, "mass"), -1.0), "[[point]] 2: mass: must be > 0"),
    (_set(("point", 0, "mass"), _DELETE), "[[point]] 1: mass: is required"),
    (_set(("point", 1, "colour"), 1.0), "[[point]] 2: colour: is not a known key"),
    (_set(("point", 1, "law", 2), "0.01/(t - 1)"),
     "[[point]] 2: law[2]: is not twice differentiable on the run"),
    (_set(("point", 0, "law", 0), "sin(t"), "[[point]] 1: law[0]: expected ')'"),
    (_set(("point", 0, "law"), ["t", "0"]), "[[point]] 1: law: must be a list of three"),
    (_set(("point", 1, "samples"), _TS), "[[point]] 2: law: give exactly one of law"),
    (_set(("point", 1, "ends"), "rest"), "[[point]] 2: ends: applies to a table or samples"),
    (_set(("point", 1, "max_distance"), 0.01), "[[point]] 2: law[0]: takes P"),
    (_set(("point", 1, "table"), "../x.csv"), "[[point]] 2: law: give exactly one"),
    (_set(("point",), [{"mass": 0.1, "law": ["0", "0", "0"]}] * 17),
     "[[point]]: at most 16 points"),
    (_set(("point", 0), 3.0), "[[point]] 1: must be a table"),
    (_set(("rotor", 0, "axis"), [0.0, 0.5, 0.5]), "[[rotor]] 1: axis: must be a unit vector"),
    (_set(("rotor", 0, "axis"), [0.0, 1.0]), "[[rotor]] 1: axis: must be a list of 3"),
    (_set(("rotor", 0, "axis"), [0.0, 0.0, 2.0]), "[[rotor]] 1: axis[2]: must be"),
    (_set(("rotor", 0, "inertia"), 0.0), "[[rotor]] 1: inertia: must be > 0"),
    (_set(("rotor", 0, "inertia"), _DELETE), "[[rotor]] 1: inertia: is required"),
    (_set(("rotor", 0, "law"), _DELETE), "[[rotor]] 1: law: is required"),
    (_set(("rotor", 0, "law"), ["t"]), "[[rotor]] 1: law: must be a string"),
    (_set(("rotor", 0, "law"), "log(t - 1)"),
     "[[rotor]] 1: law: is not twice differentiable on the run"),
    (_set(("rotor", 0, "law"), "system(1)"), "[[rotor]] 1: law: unknown name 'system'"),
    (_set(("rotor", 0, "law"), "exp(exp(exp(t*t*t)))"), "[[rotor]] 1: law: psi"),
    (_set(("rotor", 0, "mass"), 1.0), "[[rotor]] 1: mass: is not a known key"),
    (_set(("rotor",), [{"axis": [0.0, 0.0, 1.0], "inertia": 1.0, "law": "t"}] * 9),
     "[[rotor]]: at most 8 rotors"),
    (_set(("rotor",), {"axis": [0.0, 0.0, 1.0], "inertia": 1.0, "law": "t"}),
     "[rotor]: must be an array of tables"),
    (_set(("run", "model"), "planar"), "[run].model: 'planar' reads one point's law"),
    (_set(("run", "model"), "general"), "[run].model: 'general' reads one point's law"),
    (_set(("control",), {"mode": "hop"}), "[control]: closes its loop around one point's"),
    (_set(("initial", "com"), [0.0, 0.0, 0.3]), "[initial].com: the lowest point S starts"),
]


@pytest.mark.parametrize("change,message", RULES, ids=[m[:40] for _, m in RULES])
def test_each_rule_names_the_element_and_the_field(change, message):
    doc = _doc()
    change(doc)
    got = _refusal(doc)
    assert got.startswith(message), got


def test_tables_of_several_points_share_one_spline_or_are_refused():
    doc = _doc()
    doc["point"][0] = {"mass": 0.1, "samples": _TS, "ends": "periodic"}
    doc["point"][1] = {"mass": 0.1, "samples": _TS, "ends": "free"}
    assert _refusal(doc).startswith("[[point]] 2: samples: is periodic and another table")
    doc["point"][1]["ends"] = "periodic"
    doc["point"][1]["samples"] = [[t, x, y, z] for t, x, y, z in _TS[:-1]] + \
        [[2.5, 0.0, 0.0, 0.0]]
    assert "share their first and last times" in _refusal(doc)


def test_the_formulas_of_all_bodies_share_the_interpreters_workspace():
    """Each law within its own 300 operations, together past abi.LAW_MAX_NODES."""
    doc = _doc(n_points=16, n_rotors=0, duration=1.0)
    for j, p in enumerate(doc["point"]):
        p["law"] = ["+".join(f"0.0001*sin({j * 100 + k + 1}*t*t)" for k in range(22)), "0",
                    "0"]
    assert _refusal(doc).startswith("[[point]]: the laws of 16 points and no rotor have "
                                    f"more than {abi.LAW_MAX_NODES} distinct operations")


def test_toml_of_point_and_array_of_points_cannot_mix():
    text = dumps(builtin_doc()) + '\n[[point]]\nmass = 0.1\nlaw = ["t", "0", "0"]\n'
    assert _refusal(text).startswith("[point]: and [[point]] both given")


def test_an_axis_within_the_tolerance_is_normalised_and_bodies_are_carried():
    doc = _doc(n_points=3, n_rotors=2)
    doc["rotor"][1]["axis"] = [0.6, 0.8, 1e-7]
    scene = parse_scene(doc)
    assert not scene.one_point and scene.law is None
    assert [p.name for p in scene.points] == ["[[point]] 1", "[[point]] 2", "[[point]] 3"]
    assert scene.m == pytest.approx(0.05 + 0.1 + 0.15)
    a = scene.rotors[1].axis
    assert math.isclose(math.hypot(*a), 1.0, rel_tol=0, abs_tol=1e-15) and a[2] > 0
    assert scene.bodies_law.width == layout.law_width(3, 2) == 33


def test_no_point_is_valid_and_runs_as_a_bare_carrier():
    doc = builtin_doc()
    doc.pop("point")
    scene = parse_scene(doc)
    assert scene.points == () and scene.rotors == () and scene.m == 0.0
    res = simulate(doc)
    assert res.model == "moments" and res.why.startswith("no point and no rotor")
    assert res.status == "done" and res.stats["impacts"] > 0


def test_one_point_as_an_array_of_tables_runs_as_point_bit_for_bit():
    doc = builtin_doc()
    arr = copy.deepcopy(doc)
    arr["point"] = [arr["point"]]
    a, b = simulate(doc), simulate(arr)
    assert b.scene.one_point and b.scene.law is a.scene.law      # the same compiled law
    for x, y in ((a.t, b.t), (a.q, b.q), (a.event_rows, b.event_rows)):
        assert np.array_equal(x, y)


def test_toml_writer_round_trips_arrays_of_tables():
    rng = np.random.default_rng(5)
    for _ in range(30):
        doc = _doc(int(rng.integers(0, 5)), int(rng.integers(0, 4)))
        if rng.random() < 0.3:
            doc["point"].append({"mass": 0.1, "samples": _TS, "ends": "periodic"})
        text = dumps(doc)
        assert tomllib.loads(text) == doc
        if doc["point"] and doc["point"][-1].get("samples"):
            continue                             # (a table point cannot share the run)
        a, b = parse_scene(doc), parse_scene(text)
        assert [p.law_text for p in a.points] == [p.law_text for p in b.points]
        assert [(r.axis, r.inertia, r.law_text) for r in a.rotors] == \
            [(r.axis, r.inertia, r.law_text) for r in b.rotors]


# ---- the law of many outputs -----------------------------------------------------------
def _laws(rng, n_points, n_rotors):
    points = [compile_law(tuple(random_law(rng, 3) for _ in range(3)))
              for _ in range(n_points)]
    rotors = [compile_angle(random_law(rng, 3)) for _ in range(n_rotors)]
    return points, rotors


def test_many_outputs_in_c_numpy_and_sympy_agree():
    """Random laws of up to 3 points and 2 rotors as one program: the C interpreter and
    NumPy to 1e-12, and each output against SymPy's own derivatives of its expression
    to 1e-12 (relative to the values' size)."""
    rng = np.random.default_rng(32)
    t = sp.Symbol("t", real=True)
    ts = np.linspace(0.0, 2.0, 9)
    session = Session(library("general"))
    for _ in range(6):
        points, rotors = _laws(rng, int(rng.integers(1, 4)), int(rng.integers(0, 3)))
        law = combine(tuple(points), tuple(rotors))
        session.set_law(law)
        c = session.law_rows(ts).T
        npu = law.u(ts)
        scale = 1.0 + np.max(np.abs(npu))
        assert np.max(np.abs(c - npu)) < 1e-12 * scale
        outputs = [(k, e) for p in points for k, e in enumerate(p.sympy())] + \
            [(None, r.sympy()[0]) for r in rotors]
        for i, (k, expr) in enumerate(outputs):
            at, step = law.slot(i)
            for d in range(3):
                f = sp.lambdify(t, sp.diff(expr, t, d), "math")
                ref = np.array([float(f(tv)) for tv in ts])
                assert np.max(np.abs(c[at + d * step] - ref)) < \
                    1e-12 * (1.0 + np.max(np.abs(ref))), (i, d)


def test_subexpressions_common_to_bodies_are_one_node():
    a = compile_law(("0.1*sin(t*t)", "0", "0"))
    b = compile_law(("0", "0.2*sin(t*t)", "exp(0.1*sin(t*t))"))
    law = combine((a, b), (compile_angle("sin(t*t) + t"),))
    ops = law.program.ops
    # t*t and sin(t*t) once; 0.1*sin(t*t) once for point 1's x and point 2's z
    assert ops.count("sin") == 1 and ops.count("mul") == 3


def test_tables_and_formulas_in_one_law_are_each_their_own():
    """Two tables with different knots (one spline on the union) and a formula: each
    point's block of u equals its own law's evaluation, in C and in NumPy."""
    from derive.scene import table
    t1, t2 = np.linspace(0.0, 2.0, 11), np.linspace(-0.5, 2.5, 8)
    a = table.build(np.column_stack([t1, np.sin(t1), t1 ** 2, np.cos(t1)]), "free", "a")
    b = table.build(np.column_stack([t2, t2 ** 3, t2, np.exp(t2)]), "rest", "b")
    f = compile_law(("0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"))
    law = combine((a, f, b), (compile_angle("0.5*t^2"),))
    session = Session(library("general"))
    session.set_law(law)
    ts = np.linspace(0.0, 2.0, 41)
    c = session.law_rows(ts).T
    for j, own in enumerate((a, f, b)):
        want = layout.u_of_jets(own.jets(ts))
        assert np.max(np.abs(c[layout.point_slice(j)] - want)) < 1e-12 * (1 + abs(want).max())
    assert np.max(np.abs(c - law.u(ts))) < 1e-12 * (1 + np.abs(c).max())
    psi = c[layout.rotor_slice(3, 0)]
    assert np.allclose(psi, [0.5 * ts ** 2, ts, np.ones_like(ts)], rtol=0, atol=1e-15)


def test_the_runtime_refuses_a_malformed_bodies_law_and_does_not_run_one():
    lib = library("general")
    law = combine((compile_law(("t", "0", "0")), compile_law(("0", "t", "0"))), ())
    s = Session(lib)
    a = law.arrays()

    def setter(n_points=a["n_points"], n_rotors=a["n_rotors"], out=a["out"],
               n_knots=0, n_columns=0):
        from derive.runtime.build import DP, IP
        return lib.lib.crt_set_law_bodies(
            s.handle, n_points, n_rotors, out.ctypes.data_as(IP), a["n_nodes"],
            a["n_const"], a["code"].ctypes.data_as(IP), a["consts"].ctypes.data_as(DP),
            len(a["consts"]), n_knots, n_columns, a["knots"].ctypes.data_as(DP),
            a["coef"].ctypes.data_as(DP), 0)
    assert setter() == S["ok"]
    assert lib.lib.crt_law_width(s.handle) == 18
    big = np.zeros(3 * (abi.LAW_MAX_POINTS + 1), dtype=np.int32)
    assert setter(n_points=abi.LAW_MAX_POINTS + 1, out=big) == S["bad_law"]
    assert setter(n_rotors=abi.LAW_MAX_ROTORS + 1,
                  out=np.zeros(6 + abi.LAW_MAX_ROTORS + 1, dtype=np.int32)) == S["bad_law"]
    bad = a["out"].copy()
    bad[4] = a["n_nodes"]                              # a node beyond the program
    assert setter(out=bad) == S["bad_law"]
    bad[4] = -1                                        # a column of no table
    assert setter(out=bad) == S["bad_law"]
    assert lib.lib.crt_law_width(s.handle) == 0         # refused: no law
    assert setter() == S["ok"]
    from derive.runtime.driver import prepare
    prep = prepare(builtin_doc())
    with pytest.raises(SceneError, match=r"bad_law"):    # the models read one point
        s.init(prep.options, prep.parameters, 0.0, prep.start.q0)


# ---- random documents -------------------------------------------------------------------
_GOOD_LAWS = ["0.1*sin(3*t)", "0.05*cos(t)", "0", "0.02*t", "0.1*tanh(t - 1)",
              "0.05*sin(2*t)*cos(t)", "0.01*exp(-t)", "0.03*atan(t)"]
_BAD_POINT = [("mass", -1.0, "mass"), ("mass", "heavy", "mass"), ("mass", 1e30, "mass"),
              ("mass", math.inf, "mass"), ("law", ["t"], "law"), ("law", [1, 2, 3], "law[0]"),
              ("law", ["0.1/(t-1)", "0", "0"], "law[0]"), ("law", ["0", "exp(", "0"], "law[1]"),
              ("law", ["0", "0", "__import__"], "law[2]"), ("ends", "rest", "ends"),
              ("max_distance", -1.0, "max_distance"), ("spin", 1.0, "spin"),
              ("law", ["0", "0", "1e300*t*t"], "law[2]"), ("samples", [[0, 0]], "samples")]
_BAD_ROTOR = [("axis", [1.0, 1.0, 0.0], "axis"), ("axis", "z", "axis"),
              ("axis", [0.0, 0.0, math.nan], "axis[2]"), ("inertia", 0.0, "inertia"),
              ("inertia", -2.0, "inertia"), ("inertia", True, "inertia"),
              ("law", 3.0, "law"), ("law", "t +", "law"), ("law", "1/(t-0.5)", "law"),
              ("law", "sqrt(t - 1)", "law"), ("mass", 1.0, "mass"),
              ("law", "\u0661*t", "law")]


def _random_document(rng) -> tuple[dict, str | None]:
    """A random scene of 0 to 6 points and 0 to 3 rotors, and, when one element is
    broken, the start its refusal must have (else None)."""
    n_p, n_r = int(rng.integers(0, 7)), int(rng.integers(0, 4))
    doc = builtin_doc()
    doc.pop("plane") if rng.random() < 0.5 else None
    doc["run"]["duration"] = 1.0
    doc["point"] = [{"mass": float(rng.uniform(0.01, 0.3)),
                     "law": [str(rng.choice(_GOOD_LAWS)) for _ in range(3)]}
                    for _ in range(n_p)]
    if n_r:
        doc["rotor"] = []
        for _ in range(n_r):
            a = rng.normal(size=3)
            doc["rotor"].append({"axis": (a / np.linalg.norm(a)).tolist(),
                                 "inertia": float(rng.uniform(1e-3, 0.1)),
                                 "law": str(rng.choice(_GOOD_LAWS[:-1])) + " + 5*t"})
    kind = rng.random()
    if kind < 0.35 and n_p:
        j = int(rng.integers(n_p))
        key, value, field = _BAD_POINT[int(rng.integers(len(_BAD_POINT)))]
        if key == "ends":
            doc["point"][j]["ends"] = value
        elif key == "samples":
            doc["point"][j].pop("law")
            doc["point"][j]["samples"] = value
        else:
            doc["point"][j][key] = value
        return doc, f"[[point]] {j + 1}: {field}"
    if kind < 0.7 and n_r:
        r = int(rng.integers(n_r))
        key, value, field = _BAD_ROTOR[int(rng.integers(len(_BAD_ROTOR)))]
        doc["rotor"][r][key] = value
        return doc, f"[[rotor]] {r + 1}: {field}"
    if kind < 0.75:
        doc["point"] = [{"mass": 0.1, "law": ["0", "0", "0"]}] * 17
        return doc, "[[point]]: at most 16"
    if kind < 0.8 and n_r:
        doc["rotor"][0].pop(str(rng.choice(["axis", "inertia", "law"])))
        return doc, "[[rotor]] 1: "
    return doc, None


def test_random_multibody_documents_are_accepted_or_refused_naming_the_element():
    """3000 random documents (0-6 points, 0-3 rotors, about half with one broken
    element): each accepted with its bodies, or refused by a SceneError that names
    the broken element and field; nothing else is raised."""
    rng = np.random.default_rng(2032)
    accepted = refused = 0
    for i in range(3000):
        doc, want = _random_document(rng)
        try:
            scene = parse_scene(doc)
        except SceneError as exc:
            refused += 1
            assert want is not None, (i, str(exc))
            assert str(exc).startswith(want), (i, want, str(exc))
            continue
        assert want is None, (i, want)
        accepted += 1
        assert len(scene.points) == len(doc["point"])
        assert len(scene.rotors) == len(doc.get("rotor", []))
    assert accepted > 500 and refused > 1500


def test_multibody_documents_through_the_fuzz_worker_and_the_command_line():
    """A sample through the sandboxed worker (parse and simulate: a valid scene runs,
    whatever its bodies) and a few through `derive simulate` (exit 2, one line naming the
    element, nothing written)."""
    rng = np.random.default_rng(7)
    cases = []
    for i in range(40):
        doc, want = _random_document(rng)
        fields = (want.split(":")[0],) if want else ()
        cases.append(Case(i, "scene", f"bodies {i}", doc, expect="either", fields=fields))
    out = fuzz.run_api(cases, simulate=True, parse_limit=2.0, run_limit=10.0)
    assert not any(o.bad for o in out), fuzz.report(out)
    cli = [c for c in cases if c.fields][:4]
    got = fuzz.run_cli(cli, workers=2)
    assert not any(o.bad for o in got), fuzz.report(got)
    assert all(o.verdict == "refused" for o in got)


def test_the_law_of_several_bodies_is_clean_under_sanitizers(tmp_path):
    """crt_law.h's setting (crt_set_law_bodies' work) and evaluation of a law of three
    points (two periodic tables on different knots over one span, one of formulas) and
    two rotors, compiled under the strict flags with AddressSanitizer and
    UndefinedBehaviorSanitizer: the rows it prints are NumPy's, and malformed laws are
    refused without a read out of bounds."""
    import shutil
    import subprocess
    from derive.paths import GENERATED
    from derive.scene import table
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    period = 2.0
    t1, t2 = np.linspace(0.0, period, 9), np.linspace(0.0, period, 6)
    a = table.build(np.column_stack([t1, np.sin(np.pi * t1), 0 * t1, np.cos(np.pi * t1)]),
                    "periodic", "a")
    b = table.build(np.column_stack([t2, np.cos(np.pi * t2), np.sin(np.pi * t2), 0 * t2]),
                    "periodic", "b")
    f = compile_law(("0.2*sin(3*t)", "0.1*t", "0.05*cos(2*t)/(2 + sin(t))"))
    law = combine((a, f, b), (compile_angle("3*t + sin(t)"), compile_angle("0.5*t^2")))
    ar = law.arrays()
    ts = np.linspace(-1.0, 5.0, 25)

    def c_list(values, fmt=repr):
        return ", ".join(fmt(v) for v in values)
    main = f"""
#include <stdio.h>
#include "crt_law.h"
static const int code[] = {{{c_list(ar["code"].ravel().tolist(), str)}}};
static const double consts[] = {{{c_list(ar["consts"].tolist())}}};
static const int out[] = {{{c_list(ar["out"].tolist(), str)}}};
static const double knots[] = {{{c_list(ar["knots"].tolist())}}};
static const double coef[] = {{{c_list(ar["coef"].tolist())}}};
static const double ts[] = {{{c_list(ts.tolist())}}};
static crt_law law;
static crt_law_work work;

static int set(int n_points, const int *o, int n_knots)
{{
  return crt_law_set_bodies(&law, &work, n_points, 2, o, {ar["n_nodes"]}, {ar["n_const"]},
                            code, consts, {len(ar["consts"])}, n_knots, {ar["n_columns"]},
                            knots, coef, 1);
}}

int main(void)
{{
  int wrong[{len(ar["out"])}], k, i, w;
  long count = 0;
  for (k = 0; k < {len(ar["out"])}; ++k) wrong[k] = out[k];
  wrong[1] = -1 - {ar["n_columns"]};                /* a column beyond the table */
  if (set(3, wrong, {ar["n_knots"]}) != CRT_BAD_LAW) return 3;
  if (set(3, out, 1) != CRT_BAD_LAW) return 3;      /* one knot */
  if (set(CRT_LAW_MAX_POINTS + 1, out, {ar["n_knots"]}) != CRT_BAD_LAW) return 3;
  if (crt_law_u_width(&law) != 0) return 3;         /* refused: no law */
  if (set(3, out, {ar["n_knots"]}) != CRT_OK) return 4;
  w = crt_law_u_width(&law);
  /* steps end on the knots of the shared spline, across its periods */
  if (crt_law_next_knot(&law, 0.1) != knots[1]) return 5;
  if (crt_law_next_knot(&law, {period} + 0.1) != {period} + knots[1]) return 5;
  for (k = 0; k < {len(ts)}; ++k) {{
    const double *u = crt_law_eval(&law, &work, ts[k], &count);
    for (i = 0; i < w; ++i) printf("%.17g\\n", u[i]);
  }}
  return 0;
}}
"""
    src, exe = tmp_path / "bodies.c", tmp_path / "bodies"
    src.write_text(main)
    cmd = [cc, "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-O0", "-g",
           "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-I",
           str(GENERATED / "runtime"), str(src), "-o", str(exe), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    run = subprocess.run([str(exe)], capture_output=True, text=True)
    assert run.returncode == 0, (run.returncode, run.stderr[-3000:])
    got = np.array(run.stdout.split(), dtype=float).reshape(len(ts), law.width).T
    want = law.u(ts)
    assert np.max(np.abs(got - want)) < 1e-12 * (1 + np.abs(want).max())


def test_crt_init_holds_the_bodies_parameters_to_their_rule_at_its_edges():
    """crt_bodies_fault (crt_init on a moments model; a scene never sends it a broken
    rule, Python's checks come first): two points and a rotor set as the scene has them
    are taken; then each rule broken alone is refused naming that parameter: n_points and
    n_rotors one off the law's, a point's mass -1e-300; m off the points' sum by 0.98
    and 1.02 of its 1e-12 share of it (taken, refused); the rotor's |a|^2 - 1 at 0.98
    and 1.02 of 2e-9 (taken, refused; the axis scaled, not the Python's normalised one);
    its axial moment -1e-300 (and 0, taken)."""
    from derive.runtime.driver import prepare
    prep = prepare(_doc(n_points=2, n_rotors=1))
    s = Session(prep.library)
    s.set_law(prep.scene.runtime_law)
    P, ok, bad = abi.PRM, abi.STATUS["ok"], abi.STATUS["bad_parameters"]

    def status(**change):
        prm = np.array(prep.parameters, dtype=float)
        for name, value in change.items():
            prm[P[name]] = value
        code = s.init_status(prep.options, prm, prep.scene.t0, prep.start.q0)
        return code, prep.library.lib.crt_bad_parameter(s.handle) if code == bad else None
    base = np.array(prep.parameters)
    total = base[P["m_1"]] + base[P["m_2"]]
    assert base[P["m"]] == total and status() == (ok, None)
    assert status(n_points=3.0) == (bad, P["n_points"])
    assert status(n_points=1.0) == (bad, P["n_points"])
    assert status(n_rotors=0.0) == (bad, P["n_rotors"])
    assert status(m_2=-1e-300) == (bad, P["m_2"])
    for share, want in ((0.98, (ok, None)), (1.02, (bad, P["m"]))):
        for sign in (1.0, -1.0):
            assert status(m=total * (1.0 + sign * share * 1e-12)) == want, (share, sign)
    a = base[[P["a_1_x"], P["a_1_y"], P["a_1_z"]]]
    assert abs(a @ a - 1.0) < 1e-15
    for share, want in ((0.98, (ok, None)), (1.02, (bad, P["a_1_x"]))):
        for sign in (1.0, -1.0):
            b = a * math.sqrt(1.0 + sign * share * 2e-9)
            assert status(a_1_x=b[0], a_1_y=b[1], a_1_z=b[2]) == want, (share, sign)
    assert status(I_1=-1e-300) == (bad, P["I_1"])
    assert status(I_1=0.0) == (ok, None)

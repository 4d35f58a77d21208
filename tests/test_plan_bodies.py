"""Issue 32 item 5: derive plan decides any subset of the points' and rotors' laws.

Every plan is checked against something computed another way:

* a rotation about a principal axis by one wheel from rest: J omega + I psi' = 0, so the
  body turns by -I (psi(T) - psi(0)) / J_z (J_z the body's, its wheel locked in it);
* the example (three wheels, 90 degrees about a tilted axis): the written scene.toml and
  its tables re-integrated by the independent Newton-Euler formulation of
  tests/newton_euler_moments.py (SciPy, the tables read by SciPy's CubicSpline);
* one point given as [[point]] and decided: planned through the moments models, the same
  plan as the paper's model gives for [point] (reorient.toml);
* the composed moments (point_moments, rotor_moments, the kept laws in CasADi) against
  the Newton-Euler formulation's own sums of the definitions.
"""
from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

import newton_euler_moments as ne

import derive
from derive.planner.task import parse_task
from derive.scene import SceneError

EXAMPLES = Path(derive.__file__).parent / "planner" / "examples"


def _doc(name: str) -> dict:
    return tomllib.loads((EXAMPLES / name).read_text())


def _rz(angle: float) -> list:
    c, s = math.cos(angle), math.sin(angle)
    return [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]


def rotation_angle(A_target, A) -> float:
    R = np.asarray(A_target).T @ np.asarray(A)
    s = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return math.atan2(s, 0.5 * (np.trace(R) - 1))


@pytest.fixture(scope="module")
def wheels(tmp_path_factory):
    """The example, planned and written."""
    plan = derive.plan(str(EXAMPLES / "wheels.toml"))
    folder = tmp_path_factory.mktemp("wheels")
    plan.write(folder)
    return plan, folder


def test_one_wheel_turns_the_body_by_the_closed_form():
    """About a principal axis from rest, K = J_z omega + I psi' = 0 throughout: the body
    turns by -I (psi(T) - psi(0)) / J_z, so a turn of theta takes psi(T) = -J_z theta / I;
    the other axes stay still."""
    doc = _doc("wheels.toml")
    doc["rotor"] = [doc["rotor"][2]]                       # the wheel on z alone
    theta = math.radians(75.0)
    doc["plan"].update(decide=["rotor 1"], target_matrix=_rz(theta), max_rotor_rate=300.0,
                       max_rotor_acceleration=500.0)
    plan = derive.plan(doc, runtime=False)
    assert plan.ok, plan.message
    J_z, I = doc["body"]["inertia"][2], doc["rotor"][0]["inertia"]
    psi = plan.law.u(np.array([0.0, plan.law.T]))[0]
    assert abs((psi[1] - psi[0]) - (-J_z * theta / I)) <= 1e-9 * J_z * theta / I
    got = plan.summary.achieved["scipy"]
    assert got["attitude_error_rad"] < 1e-9
    assert max(abs(w) for w in got["omega_end"]) < 1e-9       # at rest again (K = 0)


def test_three_wheels_against_newton_euler(wheels):
    """The written plan (scene.toml, rotor1..3.csv) re-integrated by Newton-Euler with
    each wheel's own torque as an unknown: the target attitude at T, at rest."""
    plan, folder = wheels
    assert plan.ok, plan.message
    scene = tomllib.loads((folder / "scene.toml").read_text())
    assert [r["table"] for r in scene["rotor"]] == ["rotor1.csv", "rotor2.csv", "rotor3.csv"]
    splines = []
    for r in scene["rotor"]:
        data = np.genfromtxt(folder / r["table"], delimiter=",", names=True)
        assert r["ends"] == "rest"
        splines.append(CubicSpline(data["t"], data["psi"], bc_type=((1, 0.0), (1, 0.0))))
    body = scene["body"]

    def system(t):
        rotors = [ne.Rotor(np.array(r["axis"], float), r["inertia"], 0.4 * r["inertia"],
                           float(sp(t, 1)), float(sp(t, 2)))
                  for r, sp in zip(scene["rotor"], splines)]
        return ne.System(body["mass"], np.array(body["inertia"], float), 0.0, [], rotors)

    q0 = np.r_[np.zeros(9), np.eye(3).ravel()]
    T = scene["run"]["duration"]
    sol = solve_ivp(lambda t, q: ne.flight(system(t), q), (0.0, T), q0, method="DOP853",
                    rtol=1e-12, atol=1e-14)
    A = sol.y[9:18, -1].reshape(3, 3)
    target = np.array(_doc("wheels.toml")["plan"]["target_matrix"])
    assert rotation_angle(target, A) < 1e-8
    assert np.max(np.abs(sol.y[6:9, -1])) < 1e-8
    # the plan's own re-simulation agrees, and the bounds hold
    assert plan.summary.achieved["scipy"]["attitude_error_rad"] < 1e-9
    task = plan.task
    for b in plan.summary.law.bodies:
        assert b["max_rate"] <= task.max_rotor_rate * (1 + 1e-9)
        assert b["max_acceleration"] <= task.max_rotor_acceleration * (1 + 1e-6)


def test_the_example_writes_tables_and_a_scene_the_parser_reads(wheels):
    plan, folder = wheels
    from derive.scene import load_scene
    sc = load_scene(folder / "scene.toml")
    assert [r.law.kind for r in sc.rotors] == ["table"] * 3
    t = np.linspace(0.0, plan.law.T, 7)
    u = sc.bodies_law.u(t)
    # the rotors' columns of the runtime's law against the plan's B-spline
    assert np.max(np.abs(u[0::3] - plan.law.u(t)[0:3])) < 1e-9
    names = {p.name for p in folder.iterdir()}
    assert {"rotor1.csv", "rotor2.csv", "rotor3.csv", "scene.toml", "plan.json",
            "law.png", "motion.png"} <= names


def test_one_point_through_the_moments_models_plans_as_the_paper_model():
    """reorient.toml's point given as [[point]] and decided: the moments models'
    plan is the paper model's: the same effort to 1e-9 (the optimum is flat: IPOPT's
    two paths end within a few 1e-4 m of each other, 0.4 % of the region)."""
    doc = _doc("reorient.toml")
    paper = derive.plan(copy.deepcopy(doc), runtime=False)
    doc["point"] = [{"mass": doc["point"]["mass"]}]
    doc["plan"]["decide"] = ["point 1"]
    moments = derive.plan(doc, runtime=False)
    assert paper.ok and moments.ok
    assert abs(moments.summary.law.bodies[0]["effort"] - paper.summary.law.effort) \
        < 1e-9 * paper.summary.law.effort
    assert np.max(np.abs(paper.law.ctrl - moments.law.ctrl)) < 0.01 * 0.15
    assert moments.summary.achieved["scipy"]["attitude_error_rad"] < 1e-9


def test_composed_moments_are_the_definitions():
    """Channels.moments (a decided point and rotor, a kept point and rotor with formula
    laws evaluated in CasADi) against Newton-Euler's sums of the definitions."""
    from derive.planner.bodies import Channels
    doc = _doc("reorient.toml")
    doc["point"] = [{"mass": 0.3}, {"mass": 0.2, "law": ["0.05*sin(2*t)", "0.02*t", "0.01"]}]
    doc["rotor"] = [{"axis": [0.0, 0.6, 0.8], "inertia": 0.002, "law": "3*t + cos(t)"},
                    {"axis": [1.0, 0.0, 0.0], "inertia": 0.001}]
    doc["plan"].update(decide=["point 1", "rotor 2"], max_rotor_rate=100.0,
                       max_rotor_acceleration=100.0)
    task = parse_task(doc)
    ch = Channels(task)
    rng = np.random.default_rng(7)
    for t in (0.0, 0.37, 1.9):
        u = rng.normal(size=3 * ch.D)          # x, y, z, psi; their rates; accelerations
        kept = task.scene.points[1].law.point(t)
        psi = task.scene.rotors[0].law.jets([t])[:, 0]
        sys_ = ne.System(1.0, np.ones(3), 0.0, [
            ne.Point(0.3, u[0:3], u[4:7], u[8:11]),
            ne.Point(0.2, kept[0:3], kept[3:6], kept[6:9])], [
            ne.Rotor(np.array([0.0, 0.6, 0.8]), 0.002, 0.001, psi[1], psi[2]),
            ne.Rotor(np.array([1.0, 0.0, 0.0]), 0.001, 0.001, u[7], u[11])])
        assert np.max(np.abs(ch.moments_at(u, t) - sys_.moments())) < 1e-14


BAD = [
    (lambda d: d["plan"].pop("decide"), "[plan].decide", "is required"),
    (lambda d: d["plan"].update(decide=["wheel 1"]), "[plan].decide[0]", "must be"),
    (lambda d: d["plan"].update(decide=["rotor 4"]), "[plan].decide[0]", "has no point and 3"),
    (lambda d: d["rotor"][0].update(law="t"), "[[rotor]] 1: law", "the plan makes it"),
    (lambda d: d["plan"].update(decide=["rotor 1", "rotor 2"]), "[[rotor]] 3: law",
     "is required"),
    (lambda d: d["plan"].pop("max_rotor_rate"), "[plan].max_rotor_rate", "is required"),
    (lambda d: d["plan"].update(max_acceleration=10.0), "[plan].max_acceleration",
     "bounds a decided point"),
    (lambda d: d["plan"].update(region={"radius": 0.1}), "[plan].region",
     "places a decided point"),
    (lambda d: d["rotor"][0].update(table="psi.csv"), "[[rotor]] 1: table",
     "a task's body keeps a law"),
    (lambda d: d["plan"].update(goal="hop", apex_height=0.3), "[plan].goal", "hop plans one"),
]


@pytest.mark.parametrize("change, where, rule", BAD)
def test_bad_tasks_of_bodies_name_the_field(change, where, rule):
    doc = _doc("wheels.toml")
    change(doc)
    with pytest.raises(SceneError) as info:
        parse_task(doc)
    assert info.value.where == where, str(info.value)
    assert rule in str(info.value)


def test_decide_and_rotor_bounds_are_refused_in_a_point_task():
    doc = _doc("reorient.toml")
    for key, value in (("decide", ["point 1"]), ("max_rotor_rate", 10.0)):
        d = copy.deepcopy(doc)
        d["plan"][key] = value
        with pytest.raises(SceneError) as info:
            parse_task(d)
        assert info.value.where == f"[plan].{key}"


def test_derive_plan_says_it_does_not_use_derive_controls_tables(tmp_path, capsys):
    """A control task's [control] and [disturbance] had been validated by derive plan and
    then ignored without a word (a new user's trial): the plan says it plans the model's
    task undisturbed and that derive control reads them."""
    from derive.cli import main
    task = EXAMPLES.parent.parent / "control" / "examples" / "wheels.toml"
    assert main(["plan", str(task), "-o", str(tmp_path / "out"), "-q"]) == 0
    out = capsys.readouterr().out
    assert "[control] and [disturbance] validated, not used: derive control reads them" in out

"""A new user's trial (a dynamicist: rk4 and rtol, the state names, a forced model's why,
export's counts): small truths of the API and its docs, each pinned by the way the trial
met it.
"""
import copy

import pytest

from derive.runtime import choice
from derive.scene import parse_scene

# free flight of a body with J_x = J_y and P on its axis: auto runs the axisymmetric model
ROUND = {"name": "round", "body": {"mass": 1.0, "inertia": [0.1, 0.1, 0.14], "shape": "none"},
         "point": {"mass": 0.2, "law": ["0", "0", "0.05*cos(2*t)"]},
         "initial": {"omega": [0.5, -0.3, 1.0]}, "run": {"duration": 1.0}}


def _chosen(doc: dict, model: str) -> tuple:
    d = copy.deepcopy(doc)
    d["run"]["model"] = model
    return choice.choose(parse_scene(d))


# ---- finding 10: why a forced model runs -------------------------------------------------
def test_a_forced_model_says_what_auto_would_run_and_why_its_own_runs():
    """Forcing model = "general" on an axisymmetric scene printed "forced by [run].model;
    the pose is asked and no symmetry reduces the model": a symmetry does reduce it."""
    auto, auto_why = _chosen(ROUND, "auto")
    assert auto == "axisymmetric"
    kind, why = _chosen(ROUND, "general")
    assert kind == "general"
    assert "no symmetry reduces" not in why
    assert why.startswith("forced by [run].model in place of auto's axisymmetric")
    assert auto_why in why and "assume no symmetry" in why
    # forcing auto's own choice says so, with auto's reason
    kind, why = _chosen(ROUND, "axisymmetric")
    assert why == f"forced by [run].model, auto's choice too: {auto_why}"


@pytest.mark.parametrize("outputs", [["pose"], ["omega"]])
def test_general_chosen_by_auto_keeps_its_reason(outputs):
    doc = copy.deepcopy(ROUND)
    doc["body"]["inertia"] = [0.1, 0.12, 0.14]
    doc["run"]["outputs"] = outputs
    kind, why = _chosen(doc, "auto")
    if outputs == ["pose"]:
        assert (kind, why) == ("general", "the pose is asked and no symmetry reduces the "
                                          "model")
    else:                   # only omega asked: the attitude model answers, general is forced
        assert kind == "attitude"
        assert "assume no symmetry" in _chosen(doc, "general")[1]


# ---- finding 9: one name for a state --------------------------------------------------
def test_a_states_name_is_trajectory_csvs_and_the_primed_one_finds_it(tmp_path):
    """Result.state_names said Z_C' where trajectory.csv says dZ_C, and the README's recipe
    (end = dict(zip(res.state_names, res.q[-1]))) then met end["dZ_C"] with a bare
    KeyError.  Now the names are the file's, res.row(k) takes either spelling, and an
    unknown name's KeyError lists the row's names."""
    import numpy as np

    import derive
    from derive.runtime.outputs import write_all

    doc = {"name": "drop", "body": {"mass": 1.0, "inertia": [0.1, 0.12, 0.14],
                                    "shape": "sphere", "radius": 0.2},
           "point": {"mass": 0.2, "law": ["0.05*sin(3*t)", "0", "0"]},
           "plane": {"restitution": 0.5},
           "initial": {"com": [0.0, 0.0, 0.5], "com_velocity": [0.1, 0.0, 0.0]},
           "run": {"duration": 0.5}}
    res = derive.simulate(doc)
    write_all(res, tmp_path, plot=False)
    csv = np.genfromtxt(tmp_path / "trajectory.csv", delimiter=",", names=True)
    names = csv.dtype.names
    assert names[:19] == ("t", *res.state_names) and "dZ_C" in res.state_names
    end = res.row(-1)
    steps = res.row_kind == 0
    assert end["t"] == res.t[-1] == csv["t"][-1] and steps[-1]
    # the state against the file's last row; C's horizontal velocity as E1.1 keeps it on a
    # smooth plane, under either spelling
    for name in res.state_names:
        assert end[name] == csv[name][-1], name
    assert end["Z_C'"] == end["dZ_C"] and end["X_C'"] == end["dX_C"] == 0.1
    with pytest.raises(KeyError) as info:
        end["V_z"]
    said = str(info.value)
    assert "'V_z'" in said and all(f" {n}," in said or f" {n} " in said
                                   for n in ("t", *res.state_names))


# ---- finding 4: [run].rtol under rk4 ---------------------------------------------------
ELL = {"name": "ellipsoid tumble",
       "body": {"mass": 1.0, "inertia": [0.05, 0.08, 0.1], "shape": "ellipsoid",
                "semi_axes": [0.4, 0.3, 0.2]},
       "point": {"mass": 0.3, "law": ["0.1*sin(4*t)", "0.05*cos(3*t)", "0.03*sin(5*t)"]},
       "plane": {"restitution": 0.8},
       "initial": {"com": [0.0, 0.0, 1.0], "com_velocity": [0.2, 0.1, 0.0],
                   "omega": [2.0, -1.0, 3.0], "quaternion": [0.9, 0.3, 0.2, 0.1]},
       "run": {"duration": 3.5}}


def _ell(**run):
    import derive
    doc = copy.deepcopy(ELL)
    doc["run"].update(run)
    return derive.simulate(doc)


def test_rk4s_impacts_end_where_its_steps_resolve_them_whatever_rtol():
    """The trial's ell.toml under rk4 entered contact at 2.844 s after 12 impacts at rtol
    1e-3 and at 3.1568 after 68 at 1e-15: the rule that ends accumulating impacts read
    rtol, which no step of rk4 keeps.  Now rk4 reads neither rtol nor atol on a smooth
    plane (the same run to the bit), and its impacts and their accumulation are DOP853's
    at rtol 1e-13 (another integrator, its hops resolved to 1e-12 m)."""
    import numpy as np
    loose, tight = _ell(method="rk4", rtol=1e-3, atol=1e-3), _ell(method="rk4", rtol=1e-12)
    assert loose.stats == tight.stats and np.array_equal(loose.q, tight.q)
    assert loose.events == tight.events
    ref = _ell(method="dop853", rtol=1e-13, atol=1e-15)
    n = len(ref.impacts)
    assert n >= 60 and len(loose.impacts) >= n
    np.testing.assert_allclose(loose.impacts[:n, :2], ref.impacts[:, :2], rtol=0, atol=1e-8)
    (mine,), (theirs,) = ([e for e in r.events if e["kind"] == "contact"] for r in (loose, ref))
    assert abs(mine["t_accumulation"] - theirs["t_accumulation"]) < 1e-8
    assert 0 <= mine["t_accumulation"] - mine["t"] < 1e-5

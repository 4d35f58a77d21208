"""A dynamicist's trial (branch trial3, scratch/FINDINGS.md findings 4, 9, 10, 13): small
truths of the API and its docs, each pinned by the way the trial met it.
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

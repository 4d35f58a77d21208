"""The base model's edges (issue 33): every key of a base scene acts or is refused.

* ``[plane].restitution`` may be left out by a box or a cylinder started on its face on a
  rough plane (the base model reads it only after a lift-off), and is required by every
  other scene, as a parse error or, where the start looked like a face's but the model
  chosen is another, by the choice; either way one line naming the field, exit 2,
  nothing written;
* the ``[run]`` keys the base model does not read (method, step, keep_orthonormal) are
  refused by name when given, and accepted (their defaults) when not.
"""
import pytest

from derive.cli import main
from derive.runtime import choice
from derive.runtime.driver import simulate
from derive.scene.parse import parse_scene

_SCENE = """
[body]
mass = 1.0
inertia = [0.01, 0.02, 0.025]
shape = "{shape}"
{sizes}
[[point]]
mass = 0.4
law = ["0.05*sin(12*t)", "0", "0.02"]
[plane]
friction = {mu}
{plane}
[initial]
on_plane = {on_plane}
{initial}
[run]
duration = 0.3
{run}
"""


def _text(**kw):
    v = dict(shape="box", sizes="half_extents = [0.1, 0.06, 0.04]", mu=0.3, plane="",
             on_plane="true", initial="", run="")
    v.update(kw)
    if v["shape"] == "sphere":
        v["sizes"] = "radius = 0.05"
    return _SCENE.format(**v)


def test_a_base_scene_runs_without_restitution():
    scene = parse_scene(_text())
    assert not scene.restitution_given
    r = simulate(scene)
    assert r.model == "base" and r.status == "done"
    # the same run as with a restitution given (nothing of it is read on the face)
    with_e = simulate(parse_scene(_text(plane="restitution = 0.7")))
    assert (with_e.model_q == r.model_q).all() and (with_e.t == r.t).all()


@pytest.mark.parametrize("kw, field, says", [
    # not a face's start: the state rule asks for it
    (dict(shape="sphere"), "[plane].restitution", "is required"),
    (dict(mu=0.0), "[plane].restitution", "is required"),
    (dict(on_plane="false", initial="com = [0, 0, 1]"), "[plane].restitution", "is required"),
    # a face's start that the base model cannot run (omega off the vertical): the choice
    (dict(initial="omega = [0.5, 0, 1]"), "[plane].restitution", "model rough"),
    # the [run] keys the base model does not read
    (dict(plane="restitution = 0.5", run='method = "dopri5"'), "[run].method", "DOPRI5"),
    (dict(plane="restitution = 0.5", run="step = 1e-3"), "[run].step", "RK4"),
    (dict(plane="restitution = 0.5", run="keep_orthonormal = true"), "[run].keep_orthonormal",
     "no attitude"),
])
def test_an_unread_or_missing_key_is_refused_in_one_line(tmp_path, capsys, kw, field, says):
    path = tmp_path / "bad.toml"
    path.write_text(_text(**kw))
    out = tmp_path / "out"
    assert main(["simulate", str(path), "-o", str(out), "--no-plots"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0] and says in err[0], err
    assert not out.exists() or not any(out.iterdir())


def test_the_unread_run_keys_are_read_elsewhere():
    """The same keys on a scene of another model are taken (they act there)."""
    scene = parse_scene(_text(plane="restitution = 0.5", run='method = "dopri5"',
                              initial="omega = [0.5, 0, 1]"))
    assert choice.choose(scene)[0] == "rough"

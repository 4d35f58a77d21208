"""What a new user of capsule robots met (issue 33's new-user report), each end to end
through ``derive`` as they ran it.

* A face run that stops early (tipping, face_lifting, lift_off, at t = 0 too) writes its
  files and says its status with the time, exit 1, no traceback: the ending event has a
  ``before`` row only, which events.csv used to index past.
"""
import warnings
from pathlib import Path

import numpy as np
import pytest

from derive.cli import main

EXAMPLE = Path(__file__).parents[1] / "derive" / "scene" / "examples" / "capsule-crawler.toml"
_LAW = '["0.05*(sin(12*t) + 0.4*sin(24*t))", "0", "0.02"]'


def _crawler(tmp_path, law, extra=""):
    text = EXAMPLE.read_text().replace(_LAW, law)
    assert law in text
    text = text.replace("static_friction = 0.35", "static_friction = 0.35\n" + extra)
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


ENDS = [  # (law, [plane] extra, status, plots): each stops well inside the 10 periods
    # (events.csv names the event by its kind: abi's "liftoff" for the status lift_off)
    ('["0.05*sin(60*t)", "0", "0.02"]', "", "tipping", False),
    ('["0.05*sin(60*t)", "0", "0.02"]', 'pressure = "linear"', "face_lifting", False),
    ('["0", "0", "0.02 + 0.01*sin(80*t)"]', "", "lift_off", False),
    ('["0.5", "0", "0.5"]', "", "tipping", True),            # a point on a mast: at t = 0
]


@pytest.mark.parametrize("law, extra, status, plots", ENDS)
def test_an_early_stopped_face_run_writes_its_files_and_says_why(tmp_path, capsys, law,
                                                                 extra, status, plots):
    out = tmp_path / "out"
    args = ["simulate", str(_crawler(tmp_path, law, extra)), "-o", str(out), "-q"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")       # (a run of one instant: no singular xlim)
        rc = main(args + ([] if plots else ["--no-plots"]))
    said = capsys.readouterr().out
    assert rc == 1
    assert f": {status};" in said.splitlines()[0] and "stopped at t = " in said
    names = {"trajectory.csv", "events.csv", "impacts.csv", "summary.json"}
    assert names | ({"overview.png"} if plots else set()) <= {p.name for p in out.iterdir()}
    events = (out / "events.csv").read_text().splitlines()
    last = [line.split(",") for line in events[-2:]]
    kind = status.replace("lift_off", "liftoff")
    assert [row[:2] for row in last] == [[kind, "before"], [kind, "after"]]
    t_stop = float(last[0][2])
    traj = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1, ndmin=2)
    assert traj[-1, 0] <= t_stop + 1e-12 and t_stop < 5.0
    if plots:
        assert t_stop == 0.0

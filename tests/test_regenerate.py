"""The guide "Regenerating for a changed model" (derive/docs/regenerating.md), followed in
a scratch copy (one ``derive emit`` for both changes):

* a new surface: the capsule of the guide appended to derive/shapes.py, and a tilted
  capsule carrying a fixed point dropped on the plane, its first impact checked against
  the closed form of a rigid body struck at its lowest point (the runtime, compiled from
  the regenerated C into an empty cache, must pick the new surface up by itself);
* a new kind of internal body: the rigid pendulum of tests/regenerate_pendulum.patch (the
  files the guide names, and no other), a pendulum turning the body in free flight
  against its closed form and one dropped on the plane whose energy balance closes with
  its drive's work."""
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

# what the scratch copy runs: the drop, and the closed form computed without derive
DROP = textwrap.dedent('''
    import json, math
    import numpy as np
    import derive
    from derive import abi, layout

    R, L, M, m, e, g = 0.1, 0.3, 1.0, 0.25, 0.7, 9.81
    J = np.array([0.05, 0.06, 0.02])
    r_P = np.array([0.08, 0.0, 0.05])            # the point, fixed in the body
    theta = 0.6                                  # the tilt about the fixed x axis
    A0 = np.array([[1, 0, 0], [0, math.cos(theta), -math.sin(theta)],
                   [0, math.sin(theta), math.cos(theta)]])    # body -> fixed
    Z_C = 1.0
    res = derive.simulate({
        "name": "capsule-drop",
        "body": {"mass": M, "inertia": J.tolist(), "shape": "capsule", "radius": R,
                 "half_length": L},
        "point": {"mass": m, "law": [repr(float(x)) for x in r_P]},
        "plane": {"restitution": e},
        "initial": {"com": [0.0, 0.0, Z_C], "matrix": A0.tolist()},
        "run": {"duration": 0.6, "rtol": 1e-12, "atol": 1e-14}})

    # the closed form: the body falls without turning until S, the end of the segment
    # below plus R along -n, touches; then a rigid body struck there (Newton's e)
    nu, mt = m / (M + m), M + m
    n = A0[2]                                    # the vertical in body axes
    S = R * -n / np.linalg.norm(n) + L * np.sign(-n[2]) * np.array([0.0, 0.0, 1.0])
    CS = A0 @ (S - nu * r_P)                     # C -> S, fixed axes
    t_hit = math.sqrt(2 * (Z_C + CS[2]) / g)
    v_minus = -g * t_hit
    a, b = -nu * r_P, (1 - nu) * r_P             # O and P from C, body axes
    I_C = np.diag(J) + M * (a @ a * np.eye(3) - np.outer(a, a)) \\
        + m * (b @ b * np.eye(3) - np.outer(b, b))
    I_w = A0 @ I_C @ A0.T
    arm = np.cross(CS, [0.0, 0.0, 1.0])
    impulse = -(1 + e) * v_minus / (1 / mt + arm @ np.linalg.solve(I_w, arm))

    t_imp, I, vm, vp = res.impacts[0]
    after = np.flatnonzero(res.row_kind == abi.index(abi.ROW_KINDS, "after_event"))[0]
    q = res.q[after]
    print(json.dumps({
        "model": res.model,
        "t": [t_imp, t_hit], "I": [I, impulse], "v_minus": [vm, v_minus],
        "v_plus": [vp, -e * v_minus],
        "omega": [q[layout.GENERAL.omega].tolist(),
                  (A0.T @ np.linalg.solve(I_w, arm * impulse)).tolist()],
        "V_C": [q[layout.GENERAL.com_velocity].tolist(),
                [0.0, 0.0, v_minus + impulse / mt]]}))
''')


# a capsule that falls nearly flat, comes into contact on one end and tips over: when its
# axis passes the horizontal, S jumps to the other end, which the one-point contact
# cannot follow; the run says so instead of wiping out that end's velocity (which gained
# energy: the capsule cartwheeled end over end with status done)
TIP = textwrap.dedent('''
    import math
    import numpy as np
    import derive

    theta = math.pi / 2 - 0.05
    A0 = np.array([[1, 0, 0], [0, math.cos(theta), -math.sin(theta)],
                   [0, math.sin(theta), math.cos(theta)]])
    res = derive.simulate({
        "body": {"mass": 1.0, "inertia": [0.05, 0.05, 0.01], "shape": "capsule",
                 "radius": 0.1, "half_length": 0.3},
        "point": {"mass": 0.1, "law": ["0", "0", "0"]}, "plane": {"restitution": 0.5},
        "initial": {"com": [0.0, 0.0, 0.5], "matrix": A0.tolist()},
        "run": {"duration": 3.0}})
    print(res.status, sum(e["kind"] == "contact" for e in res.events))
''')


# the pendulum of the guide: a closed form in free flight, and a drop whose energy balance
# closes with its drive's work (the share derived in SymPy, run in C; the energy and the
# power written in NumPy)
PENDULUM = textwrap.dedent('''
    import json, math
    import numpy as np
    import derive
    from derive.runtime.motion import energy_balance, motion

    M, m, r0, J = 2.0, 0.3, 0.2, [0.4, 0.5, 0.6]
    Izz, w0, amp, nu = 0.003, 1.5, 0.8, 3.0
    res = derive.simulate({
        "name": "pendulum-spin",
        "body": {"mass": M, "inertia": J, "shape": "none"},
        "pendulum": [{"axis": [0.0, 0.0, 1.0], "arm": [r0, 0.0, 0.0], "mass": m,
                      "inertia": [0.001, 0.0, 0.0, 0.002, 0.0, Izz],
                      "law": f"{amp}*sin({nu}*t)"}],
        "initial": {"com": [0.0, 0.0, 10.0], "omega": [0.0, 0.0, w0]},
        "run": {"duration": 2.0, "rtol": 1e-12, "atol": 1e-14, "output_dt": 0.1}})
    # about z through O: K_z = (J_z + mu r^2 + G_zz) omega_z + (mu r^2 + G_zz) phi'
    mu = m * M / (m + M)
    Jz, k = J[2] + mu * r0 ** 2 + Izz, mu * r0 ** 2 + Izz
    Kz = Jz * w0 + k * amp * nu
    worst = 0.0
    for t, q in zip(res.t, res.q):
        phi, rate = amp * math.sin(nu * t), amp * nu * math.cos(nu * t)
        head = (Kz * t - k * phi) / Jz
        c, s = math.cos(head), math.sin(head)
        A = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        worst = max(worst, abs(q[8] - (Kz - k * rate) / Jz), *np.abs(q[6:8]),
                    np.abs(q[9:18] - A.ravel()).max())
    drop = derive.simulate({
        "name": "pendulum-drop",
        "body": {"mass": 1.0, "inertia": [0.02, 0.03, 0.04], "shape": "sphere",
                 "radius": 0.2},
        "pendulum": [{"hinge": [0.0, 0.0, 0.05], "axis": [0.0, 0.6, 0.8],
                      "arm": [0.1, 0.0, 0.0], "mass": 0.2,
                      "inertia": [0.001, 0.0002, 0.0, 0.002, 0.0, 0.0015],
                      "law": "1.2*sin(5*t)"}],
        "plane": {"restitution": 0.3},
        "initial": {"com": [0.0, 0.0, 0.6], "omega": [0.4, -0.3, 1.0]},
        "run": {"duration": 2.0, "rtol": 1e-11, "atol": 1e-13}})
    mo = motion(drop)
    bal = energy_balance(drop, mo)
    print(json.dumps({"models": [res.model, drop.model], "worst": worst,
                      "drop": [drop.status, drop.stats["impacts"], drop.stats["contacts"]],
                      "residual": bal["residual"] / float(np.abs(mo.E).max()),
                      "drives": list(bal["drive_work_by_body"])}))
''')


PATCH = ROOT / "tests" / "regenerate_pendulum.patch"


def _guide_block() -> str:
    text = (ROOT / "derive" / "docs" / "regenerating.md").read_text(encoding="utf-8")
    after = text.split("<!-- shape-example -->\n", 1)[1]
    return after.split("```python\n", 1)[1].split("```", 1)[0]


def _scratch(tmp_path: Path) -> Path:
    root = tmp_path / "copy"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in ("derive", "templates", "generated"):
        shutil.copytree(ROOT / name, root / name, ignore=ignore)
    shutil.copy(ROOT / "pyproject.toml", root)
    return root


def _run(root: Path, cache: Path, *args) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(root), "DERIVE_CACHE": str(cache)}
    return subprocess.run([sys.executable, *args], cwd=root, env=env, capture_output=True,
                          text=True, timeout=600)


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory):
    """A scratch copy with the guide's capsule and pendulum, emitted once: (its root, the
    compile cache it uses)."""
    tmp_path = tmp_path_factory.mktemp("regenerate")
    root = _scratch(tmp_path)
    with open(root / "derive" / "shapes.py", "a", encoding="utf-8") as f:
        f.write("\n\n" + _guide_block())
    patch = subprocess.run(["git", "apply", str(PATCH)], cwd=root, capture_output=True,
                           text=True)
    assert patch.returncode == 0, patch.stderr
    emit = _run(root, tmp_path / "cache", "-m", "derive", "emit")
    assert emit.returncode == 0, emit.stderr[-3000:]
    return root, tmp_path / "cache"


def test_a_shape_added_as_the_readme_says_reaches_a_correct_impact(regenerated):
    root, cache = regenerated
    tmp_path = cache.parent
    for name in ("c/lowest_point_capsule.c", "c/lowest_point_rate_capsule.c",
                 "casadi/lowest_point_capsule.casadi"):
        assert (root / "generated" / name).is_file(), name
    assert "CRT_SHAPE_CAPSULE" in (root / "generated/runtime/crt_abi.h").read_text()
    assert "DiracDelta" not in (root / "generated/c/jac_lowest_point_capsule.c").read_text()
    # the copy's derive is the one that runs (not the checkout's)
    where = _run(root, tmp_path / "cache", "-c", "import derive; print(derive.__file__)")
    assert where.stdout.strip().startswith(str(root)), where.stdout
    drop = _run(root, tmp_path / "cache", "-c", DROP)
    assert drop.returncode == 0, drop.stderr[-3000:]
    got = json.loads(drop.stdout.strip().splitlines()[-1])
    assert got["model"] == "general"
    for key in ("t", "I", "v_minus", "v_plus", "omega", "V_C"):
        ours, closed = (np.asarray(x, dtype=float) for x in got[key])
        assert np.allclose(ours, closed, rtol=1e-12, atol=1e-12), (key, ours, closed)
    assert any((tmp_path / "cache").glob("*/crt_general.so"))   # built from the new C
    tip = _run(root, tmp_path / "cache", "-c", TIP)
    assert tip.returncode == 0, tip.stderr[-3000:]
    status, contacts = tip.stdout.split()[-2:]
    assert (status, contacts) == ("surface_jump", "1"), tip.stdout



def test_the_patch_touches_the_files_the_readme_names():
    text = (ROOT / "derive" / "docs" / "regenerating.md").read_text(encoding="utf-8")
    block = text.split("<!-- body-kind-files -->", 1)[1].split("<!-- body-kind-files:end -->")[0]
    named = set(re.findall(r"`((?:derive|templates)/[\w/]+\.(?:py|h))`", block))
    touched = set(re.findall(r"^diff --git a/(\S+)", PATCH.read_text(encoding="utf-8"), re.M))
    assert touched == named - {"derive/runtime/drawing.py"}, (touched ^ named)


def test_a_pendulum_added_as_the_readme_says_turns_the_body_as_its_closed_form(regenerated):
    root, cache = regenerated
    assert "pendulum_moments" in (root / "generated/runtime/model_moments.c").read_text()
    assert (root / "generated/c/pendulum_moments.c").is_file()
    run = _run(root, cache, "-c", PENDULUM)
    assert run.returncode == 0, run.stderr[-3000:]
    got = json.loads(run.stdout.strip().splitlines()[-1])
    assert got["models"] == ["moments", "moments"] and got["worst"] < 1e-9, got
    status, impacts, contacts = got["drop"]
    assert status == "done" and impacts > 2 and contacts >= 1, got
    assert abs(got["residual"]) < 1e-9 and got["drives"] == ["[[pendulum]] 1"], got

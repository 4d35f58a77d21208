"""The scene runtime's C: strict flags, sanitizers, no heap, no writable statics.

A scene's rendered runtime (model section + integrators) is compiled with a small C main
that drives crt_init/crt_advance with tiny buffers (so the pause/resume path runs), under
AddressSanitizer and UndefinedBehaviorSanitizer, for a scene with impacts and resting
contact and one without a plane, with every method.
"""
from __future__ import annotations

import shutil
import subprocess

import pytest

from derive.runtime.build import render
from derive.runtime.driver import _options
from derive.runtime.scene import load_scene
from derive.runtime.scene_models import build

from test_runtime import ball, scene_dict

CC = shutil.which("cc") or shutil.which("gcc")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler")
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]

MAIN = """
#include <stdio.h>
int main(void)
{
  static const double opt[14] = {%(opt)s};
  static const double q0[NQ] = {%(q0)s};
  crt_session s;
  double t[16], q[16 * NQ], ev[8 * 5];
  int kind[16], n, n_ev, status, rows = 0, events = 0;
  status = crt_init(&s, opt, %(t0)s, q0);
  while (status == 0) {
    status = crt_advance(&s, %(t1)s, t, q, kind, 16, &n, ev, 8, &n_ev);
    rows += n;
    events += n_ev;
  }
  printf("status %%d rows %%d events %%d\\n", status, rows, events);
  return status == 1 ? 0 : 1;
}
"""


def _source(doc, method):
    doc["run"]["method"] = method
    scene = load_scene(doc)
    model = build(scene)
    src = render(model, scene.name).source
    opt = _options(scene)
    return src + MAIN % {"opt": ", ".join(repr(float(v)) for v in opt),
                         "q0": ", ".join(repr(float(v)) for v in model.q0),
                         "t0": repr(scene.t0), "t1": repr(scene.t0 + scene.duration)}


SCENES = {
    "bouncing": lambda: scene_dict(run={"duration": 2.0}),
    "contact": lambda: ball(e=0.0, z0=0.5, law=("0", "0", "0.3*sin(20*t)"), duration=0.5,
                            rtol=1e-9, atol=1e-11),
    "free": lambda: scene_dict(plane=None, run={"duration": 1.0}),
}


@pytest.mark.parametrize("method", ["rk4", "dopri5", "dop853"])
@pytest.mark.parametrize("name", list(SCENES))
def test_runtime_clean_under_sanitizers(name, method, tmp_path):
    src = tmp_path / "scene.c"
    src.write_text(_source(SCENES[name](), method))
    exe = tmp_path / "scene"
    cmd = [CC, *STRICT, "-O1", "-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
           str(src), "-o", str(exe), "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr[-3000:]
    assert "runtime error" not in run.stderr


def test_runtime_has_no_writable_statics_and_needs_only_libm(tmp_path):
    src = tmp_path / "scene.c"
    scene = load_scene(SCENES["contact"]())
    src.write_text(render(build(scene), scene.name).source)
    obj = tmp_path / "scene.o"
    subprocess.run([CC, *STRICT, "-O2", "-c", str(src), "-o", str(obj)], check=True)
    out = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
    undefined = {line.split()[1] for line in out.splitlines() if line.split()[0] == "U"}
    writable = [line for line in out.splitlines() if len(line.split()) == 3
                and line.split()[1] in "BbDdGgSs"]
    assert undefined <= {"sqrt", "pow", "sin", "cos", "sincos", "exp", "log", "tan", "atan",
                         "asin", "acos", "sinh", "cosh", "tanh"}, undefined
    assert not writable, writable

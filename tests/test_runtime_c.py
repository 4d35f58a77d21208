"""The runtime's C: strict flags, sanitizers, no heap, no writable statics.

Each model's generated runtime (``generated/runtime/model_<kind>.c``) is compiled with a
small C main (once per scene, the method chosen on its command line) that drives
crt_set_law_*/crt_init/crt_advance with tiny buffers (so the pause/resume path runs),
then crt_run_many (twice the same run: equal counters and final rows) and crt_run (the
same as the loop), under AddressSanitizer and UndefinedBehaviorSanitizer, for a scene
with impacts and resting contact, one with a tabulated law, and one without a plane,
with every method; and the rough model (crt_friction.h) on a scene whose frictional
impacts accumulate into contact that sticks, slips and lifts off, and on one that sticks,
slips and reverses while the point drives it; and the moments models (crt_bodies.h) on
scenes of three points (two of them tables sharing one spline) and two rotors, smooth
and rough, whose impacts accumulate into contact.
"""
from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from derive.paths import GENERATED
from derive import abi
from derive.runtime.driver import prepare

from test_runtime import ball, scene_dict

CC = shutil.which("cc") or shutil.which("gcc")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler")
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]

MAIN = """
#include "model_%(kind)s.c"
#include <stdio.h>
#include <stdlib.h>
%(law_data)s
static const double opts[%(n_methods)s][CRT_OPT_COUNT] = {%(opts)s};

int main(int argc, char **argv)
{
  const int which = argc > 1 ? atoi(argv[1]) : -1;
  const double *opt = which >= 0 && which < %(n_methods)s ? opts[which] : NULL;
  static const double prm[CRT_P_COUNT] = {%(prm)s};
  static const double q0[NQ] = {%(q0)s};
  crt_session s;
  double t[16], q[16 * NQ], ev[8 * CRT_EVENT_COLUMNS];
  int kind[16], n, n_ev, status, rows = 0, events = 0;
  if (opt == NULL) return 2;
  status = %(set_law)s;
  if (status != CRT_OK) return 3;
  status = crt_init(&s, opt, prm, %(t0)s, q0);
  if (status != CRT_OK) return 9;
  do {
    status = crt_advance(&s, %(t1)s, t, q, kind, 16, &n, ev, 8, &n_ev);
    rows += n;
    events += n_ev;
  } while (status == CRT_PAUSED);
  printf("status %%s rows %%d events %%d\\n", crt_status_name(status), rows, events);
  if (status != CRT_DONE) return 1;
  {
    /* the same run twice through crt_run_many (tiny scratch buffers: it resumes
       internally) and once through crt_run: the same status, counters and final row */
    double opt2[2 * CRT_OPT_COUNT], prm2[2 * CRT_P_COUNT], q02[2 * NQ], t02[2], t12[2];
    double summ[2 * CRT_SUMMARY_COUNT], last[2 * (1 + NQ)], first[2], summ1[CRT_SUMMARY_COUNT];
    double lastq[NQ];
    long stats[2 * CRT_STAT_COUNT], stats1[CRT_STAT_COUNT];
    int init[2], st[2], init1, i, k;
    for (k = 0; k < 2; ++k) {
      for (i = 0; i < CRT_OPT_COUNT; ++i) opt2[k * CRT_OPT_COUNT + i] = opt[i];
      for (i = 0; i < CRT_P_COUNT; ++i) prm2[k * CRT_P_COUNT + i] = prm[i];
      for (i = 0; i < NQ; ++i) q02[k * NQ + i] = q0[i];
      t02[k] = %(t0)s;
      t12[k] = %(t1)s;
    }
    crt_run_many(&s, 2, opt2, prm2, t02, q02, t12, t, q, kind, 16, ev, 8, init, st, stats,
                 summ, last, first);
    if (init[0] != CRT_OK || init[1] != CRT_OK || st[0] != CRT_DONE || st[1] != CRT_DONE)
      return 4;
    for (i = 0; i < CRT_STAT_COUNT; ++i)
      if (stats[i] != stats[CRT_STAT_COUNT + i]) return 5;
    for (i = 0; i < 1 + NQ; ++i)
      if (last[i] != last[1 + NQ + i]) return 6;
    status = crt_run(&s, opt, prm, %(t0)s, q0, %(t1)s, t, q, kind, 16, &n, ev, 8, &n_ev,
                     stats1, summ1, &init1);
    for (;;) {
      if (n > 0) for (i = 0; i < NQ; ++i) lastq[i] = q[(n - 1) * NQ + i];
      if (status != CRT_PAUSED) break;
      status = crt_advance(&s, %(t1)s, t, q, kind, 16, &n, ev, 8, &n_ev);
    }
    crt_stats(&s, stats1);
    if (init1 != CRT_OK || status != CRT_DONE || stats1[0] != stats[0]) return 7;
    for (i = 0; i < NQ; ++i)
      if (lastq[i] != last[1 + i]) return 8;
    printf("run_many steps %%ld first contact %%g\\n", stats[0], first[0]);
  }
  return 0;
}
"""


def _c_list(values, fmt=repr) -> str:
    return ", ".join(fmt(float(v)) if fmt is repr else fmt(v) for v in values)


def _source(make_doc, methods) -> str:
    """One program for a scene and every method (the method's options chosen by
    ``argv[1]``, its index in ``methods``): the scene compiles once."""
    return MAIN % scene_fields(make_doc, methods)


def scene_fields(make_doc, methods) -> dict:
    """A scene in C for a test program: ``kind``, ``law_data`` (static arrays),
    ``set_law`` (the call on a session ``s``), ``n_methods`` and ``opts`` (one option row
    per method), ``prm``, ``q0``, ``t0`` and ``t1``."""
    preps = []
    for method in methods:
        doc = make_doc()
        doc["run"]["method"] = method
        preps.append(prepare(doc))
    prep = preps[0]
    for other in preps[1:]:                  # only the options differ with the method
        assert other.kind == prep.kind
        assert np.array_equal(other.parameters, prep.parameters)
        assert np.array_equal(other.start.q0, prep.start.q0)
    law = prep.scene.runtime_law
    arrays = law.arrays()
    if getattr(law, "kind", "") == "bodies":
        a = arrays
        data = (f"static const int code[] = {{{_c_list(a['code'].ravel(), str)}}};\n"
                f"static const double consts[] = {{{_c_list(a['consts'])}}};\n"
                f"static const int out[] = {{{_c_list(a['out'], str)}}};\n"
                f"static const double knots[] = {{{_c_list(a['knots'])}}};\n"
                f"static const double coef[] = {{{_c_list(a['coef'])}}};\n")
        set_law = (f"crt_set_law_bodies(&s, {a['n_points']}, {a['n_rotors']}, out, "
                   f"{a['n_nodes']}, {a['n_const']}, code, consts, {len(a['consts'])}, "
                   f"{a['n_knots']}, {a['n_columns']}, knots, coef, {a['periodic']})")
    elif getattr(law, "kind", "") == "table":
        data = (f"static const double knots[] = {{{_c_list(arrays['knots'])}}};\n"
                f"static const double coef[] = {{{_c_list(arrays['coef'])}}};\n")
        set_law = (f"crt_set_law_table(&s, {len(arrays['knots'])}, knots, coef, "
                   f"{1 if law.periodic else 0})")
    else:
        data = (f"static const int code[] = {{{_c_list(arrays['code'].ravel(), str)}}};\n"
                f"static const double consts[] = {{{_c_list(arrays['consts'])}}};\n"
                f"static const int out[3] = {{{_c_list(arrays['outputs'], str)}}};\n")
        set_law = (f"crt_set_law_program(&s, {len(arrays['code'])}, {arrays['n_const']}, "
                   f"code, consts, {len(arrays['consts'])}, out)")
    opts = ", ".join("{" + _c_list(p.options) + "}" for p in preps)
    return {"kind": prep.kind, "law_data": data, "set_law": set_law,
            "n_methods": len(methods), "opts": opts, "prm": _c_list(prep.parameters),
            "q0": _c_list(prep.start.q0), "t0": repr(prep.scene.t0),
            "t1": repr(prep.scene.t0 + prep.scene.duration)}


def _table_scene():
    ts = np.linspace(0.0, 2 * np.pi / 3, 41)
    rows = [[float(t), 0.2 * np.sin(3 * t), 0.1, 0.05 * np.cos(3 * t)] for t in ts]
    rows[-1][1:] = rows[0][1:]
    doc = scene_dict(run={"duration": 1.5})
    doc["point"] = {"mass": 0.2, "samples": rows, "ends": "periodic"}
    return doc


def _spinning(**run):
    doc = ball(e=0.3, z0=0.7, law=("0.05*sin(7*t)", "0", "0.3*sin(20*t)"), duration=1.0,
               rtol=1e-9, atol=1e-11, **run)
    doc["initial"]["omega"] = [0.3, 0.0, 0.5]
    return doc


def _rough_spinning():
    doc = _spinning()
    doc["plane"]["friction"] = 0.4           # stick in impacts, contact, slip, lift-off
    return doc


def _rough_stick_slip():
    doc = ball(e=0.0, z0=0.5, law=("0.3*sin(14*t)", "0", "0"), duration=1.0, rtol=1e-9,
               atol=1e-11)
    doc["plane"]["friction"] = 0.05          # reversals, sticks and slips in contact
    return doc


def _bodies(friction: float = 0.0):
    """Three points (two periodic tables on different knots, one of formulas) and two
    rotors in a ball that lands and comes to rest: impacts accumulate into contact."""
    doc = _spinning()
    ts = np.linspace(0.0, 0.5, 11)
    rows = [[float(t), 0.05 * np.sin(4 * np.pi * t), 0.0, 0.1 * np.cos(4 * np.pi * t)]
            for t in ts]
    rows[-1][1:] = rows[0][1:]
    tab = {"mass": 0.1, "samples": rows, "ends": "periodic"}
    other = {"mass": 0.05, "samples": [[r[0], r[3], r[1], 0.0] for r in rows[::2]],
             "ends": "periodic"}
    doc["point"] = [tab, {"mass": 0.2, "law": ["0.05*sin(7*t)", "0", "0.3*sin(20*t)"]},
                    other]
    doc["rotor"] = [{"axis": [0.0, 0.0, 1.0], "inertia": 0.002, "law": "30*t + sin(5*t)"},
                    {"axis": [0.6, 0.8, 0.0], "inertia": 0.001, "law": "0.5*sin(9*t)"}]
    if friction:
        doc["plane"]["friction"] = friction
    return doc


SCENES = {
    "bouncing": lambda: scene_dict(run={"duration": 2.0}),
    "contact": lambda: ball(e=0.0, z0=0.5, law=("0", "0", "0.3*sin(20*t)"), duration=0.5,
                            rtol=1e-9, atol=1e-11),
    "table": _table_scene,
    "free": lambda: scene_dict(plane=None, run={"duration": 1.0}),
    # the general model with impacts, resting contact and lift-off (the Lie methods hand
    # over to the classical ones in contact), and the vertical and attitude models
    "general": lambda: _spinning(model="general", outputs=["pose", "impacts"]),
    "vertical": lambda: _spinning(model="vertical", outputs=["omega", "impacts"]),
    "attitude": lambda: scene_dict(plane=None, run={"duration": 1.0, "model": "attitude",
                                                    "outputs": ["omega"]}),
    "rough": _rough_spinning,
    "rough_stick_slip": _rough_stick_slip,
    "moments": _bodies,
    "moments_rough": lambda: _bodies(friction=0.4),
}


METHODS = ("rk4", "dopri5", "dop853", "lie", "lie5")


@pytest.fixture(scope="module")
def sanitized(tmp_path_factory):
    """scene name -> its program under ASan and UBSan, compiled on first use (once for
    all methods: the compile is most of the cost)."""
    built: dict = {}

    def get(name):
        if name not in built:
            folder = tmp_path_factory.mktemp(f"asan_{name}")
            src = folder / "main.c"
            src.write_text(_source(SCENES[name], METHODS))
            exe = folder / "main"
            # -O0: the sanitizers check the same, and it compiles in a quarter of the time
            cmd = [CC, *STRICT, "-O0", "-g", "-fsanitize=address,undefined",
                   "-fno-sanitize-recover=all", "-I", str(GENERATED / "runtime"), str(src),
                   "-o", str(exe), "-lm"]
            proc = subprocess.run(cmd, capture_output=True, text=True)
            assert proc.returncode == 0, proc.stderr[-3000:]
            built[name] = exe
        return built[name]
    return get


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("name", list(SCENES))
def test_runtime_clean_under_sanitizers(name, method, sanitized):
    exe = sanitized(name)
    run = subprocess.run([str(exe), str(METHODS.index(method))], capture_output=True,
                         text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr[-3000:]
    assert "runtime error" not in run.stderr


@pytest.mark.parametrize("kind", ["general", "rough", "vertical", "attitude", "translational",
                                  "planar", "axisymmetric", "variational", "moments",
                                  "moments_rough"])
def test_runtime_has_no_writable_statics_and_needs_only_libm(kind, tmp_path):
    obj = tmp_path / "model.o"
    subprocess.run([CC, *STRICT, "-O2", "-c", str(GENERATED / "runtime" / f"model_{kind}.c"),
                    "-o", str(obj)], check=True)
    out = subprocess.run(["nm", str(obj)], capture_output=True, text=True, check=True).stdout
    undefined = {line.split()[1] for line in out.splitlines() if line.split()[0] == "U"}
    writable = [line for line in out.splitlines() if len(line.split()) == 3
                and line.split()[1] in "BbDdGgSs"]
    assert undefined <= {"sqrt", "pow", "sin", "cos", "sincos", "exp", "log", "tan", "atan",
                         "atan2", "asin", "acos", "sinh", "cosh", "tanh", "fmod"}, undefined
    assert not writable, writable


CXX = shutil.which("c++") or shutil.which("g++")


@pytest.mark.skipif(CXX is None, reason="no C++ compiler")
@pytest.mark.parametrize("kind", ["general", "rough", "vertical", "translational", "planar"])
def test_runtime_headers_are_valid_cpp(kind):
    """The runtime's headers are C that is also C++ (a controller may include a model's
    file in C++; only the derived functions' C99 ``restrict`` needs the compiler's own
    spelling there)."""
    proc = subprocess.run([CXX, "-std=c++17", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
                           "-Drestrict=__restrict", "-x", "c++", "-fsyntax-only",
                           str(GENERATED / "runtime" / f"model_{kind}.c")],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]


def test_the_library_and_abi_agree_on_every_name():
    """One source of truth: the compiled name tables equal derive/abi.py (the
    library refuses to load otherwise), and the header's enums are rendered from it."""
    from derive.runtime.build import library
    lib = library("vertical")
    assert lib._names("crt_option_name", len(abi.OPTIONS)) == abi.names(abi.OPTIONS)
    header = (GENERATED / "runtime" / "crt_abi.h").read_text()
    for status in abi.STATUSES:
        assert re.search(rf"\bCRT_{status.name.upper()} = {status.code}\b", header)

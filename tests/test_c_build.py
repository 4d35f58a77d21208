"""Issue 3: the generated C as an embedder sees it.

* the shipped Makefile builds it with -std=c99 -Wall -Wextra -Wpedantic -Werror;
* it includes only <math.h> (and its own header), calls nothing but libm, and has no
  writable static data (no globals) and no heap;
* every function, through both signatures and with NULL arguments and results, runs
  clean under AddressSanitizer and UndefinedBehaviorSanitizer;
* a pure-C control loop (tests/c/control_loop.c) builds against it with the Makefile and
  keeps |K| constant between impacts.
"""
from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from derive.emit.render import GENERATED
from derive.models import all_specs

HERE = Path(__file__).parent
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
CC = shutil.which("cc") or shutil.which("gcc")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    build = tmp_path_factory.mktemp("carrier-build")
    proc = subprocess.run(["make", "-C", str(GENERATED), f"BUILD={build}"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return build


def test_makefile_builds_static_and_shared(built):
    assert (built / "libcarrier.a").is_file() and (built / "libcarrier.so").is_file()


def test_only_math_h_is_included():
    for path in sorted((GENERATED / "c").glob("*.[ch]")):
        includes = re.findall(r'#include\s+([<"][^>"]+[>"])', path.read_text())
        assert set(includes) <= {"<math.h>", '"carrier.h"'}, (path.name, includes)


def test_no_heap_no_globals_only_libm(built):
    out = subprocess.run(["nm", str(built / "libcarrier.a")], capture_output=True,
                         text=True, check=True).stdout
    undefined, writable = set(), []
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] == "U":
            undefined.add(parts[1])
        elif len(parts) == 3 and parts[1] in "BbDdGgSs":
            writable.append(parts[2])
    assert undefined <= {"sqrt", "pow", "sin", "cos", "exp", "log"}, undefined
    assert not writable, f"writable static data: {writable}"


def _harness() -> str:
    """Every function, both signatures, random inputs, NULL inputs and outputs."""
    lines = ['#include <math.h>', '#include <stdio.h>', '#include "carrier.h"', "",
             "static unsigned long long state = 88172645463325252ULL;",
             "static double rnd(void) { state ^= state << 13; state ^= state >> 7;",
             "  state ^= state << 17; return (double)(state >> 11) / 9007199254740992.0; }",
             "static void fill(double *x, int n) {",
             "  int i;", "  for (i = 0; i < n; ++i) x[i] = 0.2 + rnd();", "}",
             "static int finite(const double *x, int n) {",
             "  int i;",
             "  for (i = 0; i < n; ++i) { if (!isfinite(x[i])) return 0; }",
             "  return 1;", "}",
             "int main(void) {", "  int bad = 0, it;", "  for (it = 0; it < 2000; ++it) {"]
    for spec in all_specs():
        ins = [(v.name, len(v.entries)) for v in spec.inputs]
        outs = [(v.name, len(v.entries)) for v in spec.outputs]
        tag = spec.name
        lines.append("    {")
        for name, n in ins + outs:
            lines.append(f"      double {name}_{tag}[{n}];")
        for name, n in ins:
            lines.append(f"      fill({name}_{tag}, {n});")
        args = ", ".join(f"{name}_{tag}[0]" if n == 1 else f"{name}_{tag}"
                         for name, n in ins)
        res = ", ".join(f"{name}_{tag}" for name, _ in outs)
        lines.append(f"      carrier_{tag}({args}, {res});")
        for name, n in outs:
            lines.append(f"      if (!finite({name}_{tag}, {n})) {{ printf(\"nonfinite "
                         f"{tag}\\n\"); ++bad; }}")
        # the ABI, with every other input NULL (zeros) and the first output NULL
        arg = ", ".join("0" if k % 2 else f"{name}_{tag}" for k, (name, _) in enumerate(ins))
        out_ptrs = ", ".join("0" if k == 0 else f"{name}_{tag}" for k, (name, _) in enumerate(outs))
        lines.append(f"      {{ const double *arg[{len(ins)}] = {{{arg}}};")
        lines.append(f"        double *res[{len(outs)}] = {{{out_ptrs}}};")
        lines.append("        casadi_int n_arg, n_res, n_iw, n_w;")
        lines.append(f"        if ({tag}_work(&n_arg, &n_res, &n_iw, &n_w) || n_arg != "
                     f"{len(ins)} || n_res != {len(outs)}) ++bad;")
        lines.append(f"        if ({tag}(arg, res, 0, 0, 0)) ++bad; }}")
        lines.append("    }")
    lines += ["  }", '  printf("bad %d\\n", bad);', "  return bad != 0;", "}"]
    return "\n".join(lines) + "\n"


def test_sanitizers_clean(tmp_path):
    src = tmp_path / "harness.c"
    src.write_text(_harness())
    exe = tmp_path / "harness"
    cmd = [CC, *STRICT, "-O1", "-g", "-fsanitize=address,undefined",
           "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", "-I", str(GENERATED / "c"),
           str(src), *sorted(str(p) for p in (GENERATED / "c").glob("*.c")), "-o", str(exe),
           "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "runtime error" not in run.stderr and "AddressSanitizer" not in run.stderr
    assert "bad 0" in run.stdout


def test_pure_c_control_loop(built, tmp_path):
    exe = tmp_path / "control_loop"
    cmd = [CC, *STRICT, "-O2", "-I", str(GENERATED / "c"), str(HERE / "c" / "control_loop.c"),
           str(built / "libcarrier.a"), "-lm", "-o", str(exe)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    print(run.stdout)
    assert run.returncode == 0, run.stdout

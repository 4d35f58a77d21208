"""Issue 3: the generated C as an embedder sees it.

* the shipped Makefile builds it with -std=c99 -Wall -Wextra -Wpedantic -Werror;
* it includes only <math.h> (and its own header), calls nothing but libm, and has no
  writable static data (no globals) and no heap;
* every function, through both signatures and with NULL arguments and results, runs
  clean under AddressSanitizer and UndefinedBehaviorSanitizer;
* a pure-C control loop (tests/c/control_loop.c) builds against it with the Makefile and
  keeps |K| constant between impacts;
* (issue 15) the header and every source compile as C++17 with -Wall -Wextra -Wpedantic
  -Werror, and a C++ program (tests/c/embed.cpp: the jac_ functions through the CasADi
  ABI against the hand-derived flight Jacobian, the impact Jacobian against central
  differences) builds against the shared library with an rpath, and with CMake through
  add_subdirectory(generated).
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from derive.base import base_specs
from derive.emit.render import GENERATED
from derive.jacobians import jacobian
from derive.models import all_specs

HERE = Path(__file__).parent
STRICT = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
STRICT_CXX = ["-std=c++17", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
CC = shutil.which("cc") or shutil.which("gcc")
CXX = shutil.which("c++") or shutil.which("g++")
CMAKE = shutil.which("cmake")
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
    # (sincos: GCC joins sin and cos of one argument, the base model's yaw, into glibc's
    # libm call; the source calls sin and cos)
    assert undefined <= {"sqrt", "pow", "sin", "cos", "sincos", "exp", "log"}, undefined
    assert not writable, f"writable static data: {writable}"


def _functions() -> list[tuple]:
    """(name, plain inputs, plain outputs, ABI inputs, ABI outputs) of every generated
    function and its jac_: the jac_ takes the nominal outputs too and returns every block
    (the identically zero ones only through the ABI)."""
    out = []
    for spec in all_specs() + base_specs():
        ins = [(v.name, len(v.entries)) for v in spec.inputs]
        outs = [(v.name, len(v.entries)) for v in spec.outputs]
        out.append((spec.name, ins, outs, len(ins), len(outs)))
        jac = jacobian(spec)
        jouts = [(v.name, len(v.entries)) for v in jac.spec.outputs]
        out.append((jac.name, ins, jouts, len(ins) + len(outs), len(jac.blocks)))
    return out


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
    for tag, ins, outs, n_arg, n_res in _functions():
        lines.append("    {")
        for name, n in ins + outs:
            lines.append(f"      double {name}_{tag}[{n}];")
        for name, n in ins:
            lines.append(f"      fill({name}_{tag}, {n});")
        args = ", ".join(f"{name}_{tag}[0]" if n == 1 else f"{name}_{tag}"
                         for name, n in ins)
        res = ", ".join(f"{name}_{tag}" for name, _ in outs)
        lines.append(f"      carrier_{tag}({', '.join(x for x in (args, res) if x)});")
        for name, n in outs:
            lines.append(f"      if (!finite({name}_{tag}, {n})) {{ printf(\"nonfinite "
                         f"{tag}\\n\"); ++bad; }}")
        # the ABI, with every other input NULL (zeros) and the first output NULL; a
        # jac_ gets NULL nominal outputs and writes its blocks into one buffer each
        arg = ", ".join("0" if k % 2 or k >= len(ins) else f"{ins[k][0]}_{tag}"
                        for k in range(n_arg))
        lines.append(f"      {{ const double *arg[{n_arg}] = {{{arg}}};")
        lines.append(f"        double *res[{n_res}];")
        lines.append("        double buffer[4096];")
        lines.append("        casadi_int n_arg, n_res, n_iw, n_w, k, used = 0;")
        lines.append(f"        for (k = 0; k < {n_res}; ++k) {{")
        lines.append(f"          const casadi_int *sp = {tag}_sparsity_out(k);")
        lines.append("          res[k] = k == 0 ? 0 : buffer + used;")
        lines.append("          used += sp[2] == 1 ? sp[0] * sp[1] : sp[2 + sp[1]];")
        lines.append("        }")
        lines.append(f"        if ({tag}_work(&n_arg, &n_res, &n_iw, &n_w) || n_arg != "
                     f"{n_arg} || n_res != {n_res} || {tag}_n_in() != {n_arg}) ++bad;")
        lines.append(f"        if (used > 4096 || {tag}(arg, res, 0, 0, 0)) ++bad; }}")
        lines.append("    }")
    lines += ["  }", '  printf("bad %d\\n", bad);', "  return bad != 0;", "}"]
    return "\n".join(lines) + "\n"


def test_sanitizers_clean(tmp_path):
    src = tmp_path / "harness.c"
    src.write_text(_harness())
    exe = tmp_path / "harness"
    # -O0: the sanitizers check the same at every level, and ~100 sources compile in a
    # quarter of -O1's time
    flags = [*STRICT, "-O0", "-g", "-fsanitize=address,undefined", "-fno-sanitize-recover=all",
             "-fno-omit-frame-pointer", "-I", str(GENERATED / "c")]
    sources = [src, *sorted((GENERATED / "c").glob("*.c"))]

    def compile_one(path):     # one object per source, two at a time
        obj = tmp_path / (path.stem + ".o")
        proc = subprocess.run([CC, *flags, "-c", str(path), "-o", str(obj)],
                              capture_output=True, text=True)
        return obj, proc

    with ThreadPoolExecutor(max_workers=2) as pool:
        compiled = list(pool.map(compile_one, sources))
    for _, proc in compiled:
        assert proc.returncode == 0, proc.stderr
    link = subprocess.run([CC, *flags, *[str(obj) for obj, _ in compiled], "-o", str(exe),
                           "-lm"], capture_output=True, text=True)
    assert link.returncode == 0, link.stderr
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


@pytest.mark.skipif(CXX is None, reason="no C++ compiler")
def test_without_the_casadi_abi_every_symbol_is_prefixed(tmp_path):
    """make with CFLAGS=-DCARRIER_NO_CASADI_ABI: the library's defined symbols are all
    carrier_ (a controller with its own exp_map links against it and includes carrier.h,
    which a new-user trial found clashing), and such a program builds strictly.  At -O0:
    what is checked is the symbols defined (the same at every level) and that the
    sources build strictly without the ABI; the functions' bodies are built at the
    Makefile's -O2 by the fixture ``built`` (and at -O3 by CMake in test_wheel.py), and
    -O0 compiles the ~100 sources in about a third of -O2's time."""
    build = tmp_path / "b"
    proc = subprocess.run(["make", "-C", str(GENERATED), f"BUILD={build}",
                           "CFLAGS=-O0 -DCARRIER_NO_CASADI_ABI"], capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    out = subprocess.run(["nm", "-g", "--defined-only", str(build / "libcarrier.a")],
                         capture_output=True, text=True, check=True).stdout
    names = [line.split()[2] for line in out.splitlines() if len(line.split()) == 3]
    assert len(names) == len(list((GENERATED / "c").glob("*.c")))
    assert all(n.startswith("carrier_") for n in names), [n for n in names
                                                         if not n.startswith("carrier_")]
    app = tmp_path / "app.c"
    app.write_text('#include "carrier.h"\n'
                   "static double exp_map(double x) { return x; }\n"
                   "int lie_stage(void) { return 0; }\n"
                   "int main(void) { double W[3] = {0.1, 0.2, 0.3}, E[9], q[4];\n"
                   "  carrier_exp_map(W, E, q); return exp_map(E[0]) > 1.0 + lie_stage(); }\n")
    proc = subprocess.run([CC, *STRICT, "-DCARRIER_NO_CASADI_ABI", "-I", str(GENERATED / "c"),
                           str(app), str(build / "libcarrier.a"), "-lm", "-o",
                           str(tmp_path / "app")], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert subprocess.run([str(tmp_path / "app")]).returncode == 0


def test_header_and_sources_compile_as_cpp17(tmp_path):
    """carrier.h (restrict behind CARRIER_RESTRICT) and all sources, one C++ unit."""
    unit = tmp_path / "all.cpp"
    unit.write_text("".join(f'#include "{p.name}"\n'
                            for p in sorted((GENERATED / "c").glob("*.c"))))
    proc = subprocess.run([CXX, *STRICT_CXX, "-fsyntax-only", "-I", str(GENERATED / "c"),
                           str(unit)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-4000:]


@pytest.mark.skipif(CXX is None, reason="no C++ compiler")
def test_cpp_program_against_the_shared_library(built, tmp_path):
    """tests/c/embed.cpp linked to libcarrier.so with an rpath (the embedding guide's
    recipe): it runs without LD_LIBRARY_PATH."""
    exe = tmp_path / "embed"
    cmd = [CXX, *STRICT_CXX, "-O2", "-I", str(GENERATED / "c"), str(HERE / "c" / "embed.cpp"),
           f"-L{built}", "-lcarrier", "-lm", f"-Wl,-rpath,{built}", "-o", str(exe)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-4000:]
    env = {k: v for k, v in os.environ.items() if k != "LD_LIBRARY_PATH"}
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120, env=env)
    print(run.stdout)
    assert run.returncode == 0, run.stdout + run.stderr


@pytest.mark.skipif(CMAKE is None or CXX is None, reason="no cmake or no C++ compiler")
def test_cmake_add_subdirectory(tmp_path):
    """tests/c/CMakeLists.txt builds embed.cpp with add_subdirectory(generated) and the
    target carrier::carrier (static).  CMake's Debug type (-g, no optimisation): what is
    checked is how the target is added and found, and that embed runs; the Release
    build (-O3, -Werror) of the same CMakeLists.txt is test_wheel.py's, and Debug
    compiles the ~100 sources in about a third of its time."""
    build = tmp_path / "build"
    configure = subprocess.run(
        [CMAKE, "-S", str(HERE / "c"), "-B", str(build), f"-DCARRIER_SOURCE_DIR={GENERATED}",
         "-DCMAKE_BUILD_TYPE=Debug", "-DCMAKE_C_FLAGS=-Werror",
         "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON"],
        capture_output=True, text=True)
    assert configure.returncode == 0, configure.stdout[-3000:] + configure.stderr[-3000:]
    # what the embedding guide says: added with add_subdirectory, the header folder is
    # an ordinary one (-I), so the project's own warnings check carrier.h
    import json
    commands = json.loads((build / "compile_commands.json").read_text())
    embed = next(c["command"] for c in commands if c["file"].endswith("embed.cpp"))
    assert f"-I{GENERATED / 'c'}" in embed and "-isystem" not in embed, embed
    make = subprocess.run([CMAKE, "--build", str(build), "--parallel", "2"],
                          capture_output=True, text=True)
    assert make.returncode == 0, make.stdout[-3000:] + make.stderr[-3000:]
    run = subprocess.run([str(build / "embed")], capture_output=True, text=True, timeout=120)
    print(run.stdout)
    assert run.returncode == 0, run.stdout + run.stderr

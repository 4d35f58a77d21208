"""The runtime's hand-written headers (templates/runtime/*.h) form a stack: each includes
only headers below it, and no header calls a function that only a header above it
defines (issue 31; farm-studio draws the same picture).  Checked on the headers' own
text, against their #include lines, with a mutation that must be caught; and
Darboux-Keller's crt_dk.h compiled alone, with nothing of the runtime but crt_math.h and
the ABI's codes.
"""
from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from derive.paths import GENERATED, TEMPLATES

RUNTIME = TEMPLATES / "runtime"
# a function's definition starts at the line's start: its type, then its name
DEFINITION = re.compile(r"^(?:static )?(?:inline )?(?:const )?(?:enum |struct )?\w+ \**(crt_\w+)\(",
                        re.M)
INCLUDE = re.compile(r'^#include "([\w.]+)"', re.M)


def _code(text: str) -> str:
    """The text without comments and string literals."""
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    return re.sub(r'"(?:\\.|[^"\\])*"', '""', text)


def headers(overrides: dict | None = None) -> dict:
    found = {p.name: p.read_text(encoding="utf-8") for p in sorted(RUNTIME.glob("*.h"))}
    found.update(overrides or {})
    return found


def below(texts: dict) -> dict:
    """Every header's includes, followed down (a header's own name excluded)."""
    direct = {name: set(INCLUDE.findall(text)) for name, text in texts.items()}
    reach = {}

    def walk(name, seen):
        for inc in direct.get(name, ()):
            if inc not in seen:
                seen.add(inc)
                walk(inc, seen)
        return seen
    for name in direct:
        reach[name] = walk(name, set())
    return reach


def upward_calls(texts: dict) -> list:
    """(caller header, function, header that defines it) where a header calls a function
    defined only in headers that are not below it."""
    defined = {}
    for name, text in texts.items():
        for fn in DEFINITION.findall(_code(text)):
            defined.setdefault(fn, set()).add(name)
    reach = below(texts)
    found = []
    for name, text in texts.items():
        code = _code(text)
        for fn, homes in defined.items():
            if name in homes or not re.search(rf"\b{fn}\s*\(", code):
                continue
            # a hook defined by every variant (crt_contact_*: crt_smooth.h, crt_rough.h and
            # the no-plane branch of crt_contact.h) counts as below when any variant is
            if not homes & (reach[name] | {name}):
                found.append((name, fn, sorted(homes)))
    return found


def test_the_headers_include_no_circle():
    reach = below(headers())
    assert [name for name, under in reach.items() if name in under] == []


def test_no_header_calls_one_above_it_and_the_check_can_fail():
    assert upward_calls(headers()) == []
    # mutation: the session header calling the loop's right-hand side is caught
    text = headers()["crt_session.h"].replace(
        "static const double *crt_u(crt_session *s, double t)\n{",
        "static const double *crt_u(crt_session *s, double t)\n{\n  crt_rhs(s, t, 0, 0);", 1)
    mutated = headers({"crt_session.h": text})
    # (crt_rhs is the loop's in crt_rhs.h, the base model's in crt_base_flow.h: both above)
    assert ("crt_session.h", "crt_rhs", ["crt_base_flow.h", "crt_rhs.h"]) in upward_calls(mutated)


def test_darboux_keller_compiles_alone(tmp_path):
    """crt_dk.h needs only crt_math.h, the ABI's codes, its rendered DOP853 step and the
    three emitted impulse functions of the rough model (declared here, not defined):
    no session, no runtime."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    src = tmp_path / "dk_alone.c"
    src.write_text(
        "void impulse_slip_direction_rate(const double *sigma, const double *W, double mu_f,\n"
        "                                 double *dv);\n"
        "void impulse_stick_rate(const double *y, const double *W, double mu_f, double *dy,\n"
        "                        double *tau, double *margin);\n"
        "void impulse_resliding(const double *W, double mu_f, double c, double *sigma,\n"
        "                       double *f, double *df_dc);\n"
        '#include "crt_dk.h"\n'
        "int dk_alone(const double *w6, const double *v0, double *P)\n"
        "{\n"
        "  crt_dk_result r;\n"
        "  const int status = crt_dk_impact(w6, v0, 0.5, 0.3, CRT_RESTITUTION_ENERGETIC,\n"
        "                                  1e-10, &r);\n"
        "  if (status != CRT_OK) return status;\n"
        "  P[0] = r.P[0]; P[1] = r.P[1]; P[2] = r.P[2];\n"
        "  return status;\n"
        "}\n", encoding="utf-8")
    only = tmp_path / "inc"
    only.mkdir()
    for name in ("crt_dk.h", "crt_dk_steps.h", "crt_math.h", "crt_abi.h", "crt_constants.h"):
        shutil.copy(GENERATED / "runtime" / name, only / name)
    proc = subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-O1",
                           "-I", str(only), "-c", str(src), "-o", str(tmp_path / "dk.o")],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]

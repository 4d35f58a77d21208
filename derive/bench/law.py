"""``derive bench law``: how to evaluate the point law at run time, by measurement.

Two ways, for the same laws:

* the runtime's interpreter (``crt_law.h``): the law is data (a program of a few opcodes
  and a table of constants), evaluated in one forward pass with its first two
  derivatives; no compiler is involved, so a new law costs nothing to load;
* straight-line C for the same program (printed here from the program's numbers and
  opcodes only), compiled with the runtime's flags: what compiling each law would give,
  at the price of a compiler run per new law.

Reported: ns per evaluation (value and two derivatives of x, y, z) for both, the compile
time of one law, the number of law evaluations in a run of the built-in scene and the
share of that run the interpreter costs — so the choice can be read off the table.
Targets: the two agree (the interpreter computes what the program says), and compiling
a law pays back only after more than ``PAYBACK`` runs of it (else the interpreter would
not be the right choice).
"""
from __future__ import annotations

import ctypes
import shutil
import time

import numpy as np

from ..cbuild import build_shared, runtime_flags
from ..commands import Target
from ..runtime.build import DP
from .routes import _timed

AGREEMENT = 1e-12   # max |interpreted - compiled| / max |compiled| over the values and rates
PAYBACK = 100       # runs of one law before compiling it would pay back, at least

LAWS = {
    "built-in": ("0.2*sin(3*t)", "0.1", "0.05*cos(2*t)"),
    "two harmonics": ("0.15*sin(2*t) + 0.05*cos(5*t)", "0.08*cos(3*t)",
                      "0.1*sin(4*t + 0.3)"),
    "elaborate": ("0.1*tanh(2*t)*exp(-0.1*t)*cos(3*t)", "0.05*sqrt(1 + t^2)",
                  "0.02*atan(t)/(1 + 0.1*t^2)"),
}


def _c(x: float) -> str:
    return repr(float(x))


def straight_line_c(program) -> str:
    """C computing u = (x, y, z, x', y', z', x'', y'', z'') of ``program`` for n times;
    built from opcodes and numbers only (nothing of the law's text)."""
    lines = ["#include <math.h>",
             "void law_rows(int n, const double *t, double *u)", "{", "  int k;",
             "  for (k = 0; k < n; ++k) {"]
    ops, a, b, consts = program.ops, program.a, program.b, program.consts

    def v(i, d):
        return f"v{i}_{d}"
    for i, op in enumerate(ops):
        decl = "    const double "
        if op == "const":
            lines.append(f"{decl}{v(i, 0)} = {_c(consts[a[i]])}, {v(i, 1)} = 0.0, "
                         f"{v(i, 2)} = 0.0;")
            continue
        if op == "t":
            lines.append(f"{decl}{v(i, 0)} = t[k], {v(i, 1)} = 1.0, {v(i, 2)} = 0.0;")
            continue
        if op in ("hsin", "hcos"):
            A, w, ph = (_c(c) for c in consts[a[i]:a[i] + 3])
            f, g, sg = ("sin", "cos", "") if op == "hsin" else ("cos", "sin", "-")
            lines.append(f"{decl}th{i} = {w} * t[k] + {ph}, s{i} = {f}(th{i}), "
                         f"c{i} = {g}(th{i});")
            lines.append(f"{decl}{v(i, 0)} = {A} * s{i}, {v(i, 1)} = {sg}({A} * {w}) * c{i}, "
                         f"{v(i, 2)} = -({A} * {w} * {w}) * s{i};")
            continue
        x = [v(a[i], d) for d in range(3)]
        if op in ("add", "sub"):
            y = [v(b[i], d) for d in range(3)]
            sg = "+" if op == "add" else "-"
            lines.append(decl + ", ".join(f"{v(i, d)} = {x[d]} {sg} {y[d]}" for d in range(3))
                         + ";")
        elif op == "neg":
            lines.append(decl + ", ".join(f"{v(i, d)} = -{x[d]}" for d in range(3)) + ";")
        elif op == "mul":
            y = [v(b[i], d) for d in range(3)]
            lines.append(f"{decl}{v(i, 0)} = {x[0]} * {y[0]}, {v(i, 1)} = {x[1]} * {y[0]} + "
                         f"{x[0]} * {y[1]}, {v(i, 2)} = {x[2]} * {y[0]} + 2.0 * {x[1]} * "
                         f"{y[1]} + {x[0]} * {y[2]};")
        elif op == "div":
            y = [v(b[i], d) for d in range(3)]
            lines.append(f"{decl}inv{i} = 1.0 / {y[0]}, {v(i, 0)} = {x[0]} * inv{i}, "
                         f"{v(i, 1)} = ({x[1]} - {v(i, 0)} * {y[1]}) * inv{i}, {v(i, 2)} = "
                         f"({x[2]} - 2.0 * {v(i, 1)} * {y[1]} - {v(i, 0)} * {y[2]}) * inv{i};")
        elif op in ("powi", "powr"):
            r = _c(consts[b[i]])
            lines.append(f"{decl}p2_{i} = pow({x[0]}, {r} - 2.0), p1_{i} = p2_{i} * {x[0]}, "
                         f"{v(i, 0)} = p1_{i} * {x[0]}, {v(i, 1)} = {r} * p1_{i} * {x[1]}, "
                         f"{v(i, 2)} = {r} * ({r} - 1.0) * p2_{i} * {x[1]} * {x[1]} + {r} * "
                         f"p1_{i} * {x[2]};")
        else:
            f = {"sin": ("sin(X)", "cos(X)", "-sin(X)"), "cos": ("cos(X)", "-sin(X)", "-cos(X)"),
                 "exp": ("exp(X)",) * 3, "tanh": ("tanh(X)", "1.0 - F0 * F0",
                                                  "-2.0 * F0 * (1.0 - F0 * F0)"),
                 "sqrt": ("sqrt(X)", "0.5 / F0", "-0.25 / (F0 * X)"),
                 "atan": ("atan(X)", "1.0 / (1.0 + X * X)", "-2.0 * X * F1 * F1"),
                 "log": ("log(X)", "1.0 / X", "-F1 * F1"),
                 "tan": ("tan(X)", "1.0 + F0 * F0", "2.0 * F0 * F1"),
                 "sinh": ("sinh(X)", "cosh(X)", "F0"), "cosh": ("cosh(X)", "sinh(X)", "F0"),
                 "asin": ("asin(X)", "1.0 / sqrt(1.0 - X * X)", "X * F1 * F1 * F1"),
                 "acos": ("acos(X)", "-1.0 / sqrt(1.0 - X * X)", "X * F1 * F1 * F1")}.get(op)
            if f is None:
                raise ValueError(f"no straight-line form for {op}")
            f0 = f[0].replace("X", x[0])
            f1 = f[1].replace("X", x[0]).replace("F0", f"f0_{i}")
            f2 = f[2].replace("X", x[0]).replace("F0", f"f0_{i}").replace("F1", f"f1_{i}")
            lines.append(f"{decl}f0_{i} = {f0}, f1_{i} = {f1}, f2_{i} = {f2};")
            lines.append(f"{decl}{v(i, 0)} = f0_{i}, {v(i, 1)} = f1_{i} * {x[1]}, {v(i, 2)} = "
                         f"f2_{i} * {x[1]} * {x[1]} + f1_{i} * {x[2]};")
    for c, node in enumerate(program.outputs):
        for d in range(3):
            lines.append(f"    u[9L * k + {3 * d + c}] = {v(node, d)};")
    lines += ["  }", "}", ""]
    return "\n".join(lines)


def _fresh_build(source: str):
    """Compile the law as a new law would be: into an empty cache (what a user pays the
    first time), then keep the library for timing."""
    import os
    import tempfile
    keep = tempfile.mkdtemp(prefix="derive-law-")
    before = os.environ.get("DERIVE_CACHE")
    os.environ["DERIVE_CACHE"] = keep
    try:
        start = time.perf_counter()
        path = build_shared({"law.c": source}, flags=runtime_flags(), name="law")
        return path, time.perf_counter() - start
    finally:
        if before is None:
            os.environ.pop("DERIVE_CACHE")
        else:
            os.environ["DERIVE_CACHE"] = before


def run(n: int = 200_000, repeats: int = 7, progress=lambda m: None) -> dict:
    from ..runtime.driver import prepare
    from ..runtime.session import Session
    from ..scene import builtin_doc
    rows = []
    ts = np.linspace(0.0, 5.0, n)
    for name, texts in LAWS.items():
        progress(name)
        doc = builtin_doc()
        doc["point"]["law"] = list(texts)
        prep = prepare(doc)
        session = Session(prep.library)
        session.set_law(prep.scene.law)
        session.init(prep.options, prep.parameters, 0.0, prep.start.q0)
        u_interp = np.zeros((n, 9))
        tp, up = ts.ctypes.data_as(DP), u_interp.ctypes.data_as(DP)
        lib = prep.library.lib
        interp = _timed(lambda: lib.crt_law_rows(session.handle, n, tp, up), repeats) / n
        source = straight_line_c(prep.scene.law)
        path, compile_s = _fresh_build(source)
        cl = ctypes.CDLL(str(path))
        shutil.rmtree(path.parents[1], ignore_errors=True)   # loaded: the files can go
        cl.law_rows.argtypes = [ctypes.c_int, DP, DP]
        u_comp = np.zeros((n, 9))
        cp = u_comp.ctypes.data_as(DP)
        compiled = _timed(lambda: cl.law_rows(n, tp, cp), repeats) / n
        agree = float(np.max(np.abs(u_interp - u_comp)) / max(np.max(np.abs(u_comp)), 1e-300))
        # a run of the scene: how many law evaluations, and what the interpreter costs of it
        raw = session.run(prep.scene.t0, prep.scene.duration, prep.start.q0, prep.options,
                          prep.parameters)
        run_s = _timed(lambda: session.run(prep.scene.t0, prep.scene.duration,
                                           prep.start.q0, prep.options, prep.parameters),
                       repeats)
        evals = raw.stats["law_evaluations"]
        rows.append({"law": name, "nodes": len(prep.scene.law.ops), "interpreted_ns": 1e9 *
                     interp, "compiled_ns": 1e9 * compiled, "compile_ms": 1e3 * compile_s,
                     "agreement": agree, "evaluations_per_run": evals, "run_ms": 1e3 * run_s,
                     "interpreter_share": evals * interp / run_s,
                     "saving_ms": 1e3 * evals * (interp - compiled)})
    return {"rows": rows}


def report(out: dict) -> str:
    lines = [f"{'law':<15}{'nodes':>6}{'interp ns':>11}{'compiled ns':>13}{'compile ms':>12}"
             f"{'agree':>9}{'evals/run':>11}{'run ms':>9}{'interp share':>14}"]
    for r in out["rows"]:
        lines.append(f"{r['law']:<15}{r['nodes']:>6}{r['interpreted_ns']:>11.1f}"
                     f"{r['compiled_ns']:>13.1f}{r['compile_ms']:>12.1f}{r['agreement']:>9.0e}"
                     f"{r['evaluations_per_run']:>11d}{r['run_ms']:>9.3f}"
                     f"{100 * r['interpreter_share']:>13.1f}%")
    worst, runs = _payback(out)
    lines.append(f"compiling a law would save at most {worst['saving_ms']:.3f} ms per run of "
                 f"the built-in scene ({worst['law']}) and costs {worst['compile_ms']:.0f} ms "
                 f"per new law: it pays only after {runs:.0f} runs of one law, and needs a "
                 f"compiler at run time")
    lines += [f"goal: {t}" for t in targets(out)]
    return "\n".join(lines)


def _payback(out: dict) -> tuple[dict, float]:
    """The law whose compiling would save the most per run, and the runs it takes for
    that saving to repay its compile time."""
    worst = max(out["rows"], key=lambda r: r["saving_ms"])
    return worst, worst["compile_ms"] / max(worst["saving_ms"], 1e-12)


def targets(out: dict) -> list[Target]:
    agree = max(r["agreement"] for r in out["rows"])
    _, runs = _payback(out)
    return [Target(f"interpreted and compiled agree to {agree:.0e} (target <= "
                   f"{AGREEMENT:g})", bool(agree <= AGREEMENT)),
            Target(f"compiling pays back after {runs:.0f} runs of one law (the interpreter "
                   f"stays the choice while that is > {PAYBACK})", bool(runs > PAYBACK))]


def passed(out: dict) -> bool:
    return all(t.ok for t in targets(out))

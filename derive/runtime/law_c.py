"""A scene's law as straight-line C: each output's value and first two derivatives in t.

``derive export`` writes ``scene_law_jets(t, u)`` from the law's compiled expression tree
(:class:`derive.scene.law.program.Program`), not from its text: one ``const double`` triple
(value, d/dt, d2/dt2) per node the outputs reach, by forward differentiation node by node
(the product and quotient rules, the chain rule with each function's first and second
derivatives), the numbers printed from the parsed floats.  The runtime interprets the same
tree (crt_law.h); tests/test_export.py compares the two, and NumPy's jets of the tree.  A
law with a table (one point's, or a column of several bodies') has no such function: its
table is the data, its jets the runtime's (``scene_law``).
"""
from __future__ import annotations

import re

# the first and second derivative of each function of one argument, in C of ``x`` (the
# argument's value) and ``f`` (the function's value, already computed)
_UNARY = {
    "sin": ("sin({x})", "cos({x})", "-{f}"),
    "cos": ("cos({x})", "-sin({x})", "-{f}"),
    "tan": ("tan({x})", "1.0 + {f} * {f}", "2.0 * {f} * (1.0 + {f} * {f})"),
    "exp": ("exp({x})", "{f}", "{f}"),
    "log": ("log({x})", "1.0 / {x}", "-1.0 / ({x} * {x})"),
    "sqrt": ("sqrt({x})", "0.5 / {f}", "-0.25 / ({f} * {x})"),
    "sinh": ("sinh({x})", "cosh({x})", "{f}"),
    "cosh": ("cosh({x})", "sinh({x})", "{f}"),
    "tanh": ("tanh({x})", "1.0 - {f} * {f}", "-2.0 * {f} * (1.0 - {f} * {f})"),
    "asin": ("asin({x})", "1.0 / sqrt(1.0 - {x} * {x})",
             "{x} / ((1.0 - {x} * {x}) * sqrt(1.0 - {x} * {x}))"),
    "acos": ("acos({x})", "-1.0 / sqrt(1.0 - {x} * {x})",
             "-{x} / ((1.0 - {x} * {x}) * sqrt(1.0 - {x} * {x}))"),
    "atan": ("atan({x})", "1.0 / (1.0 + {x} * {x})",
             "-2.0 * {x} / ((1.0 + {x} * {x}) * (1.0 + {x} * {x}))"),
}


def _constant(jet: tuple) -> bool:
    return jet[1] == "0.0" and jet[2] == "0.0"


class Unsupported(ValueError):
    """An opcode the emitter does not know (a newer law compiler): no jets function."""


def _reach(program, outputs) -> list[int]:
    """The nodes the outputs need, in the program's (topological) order."""
    need, todo = set(), list(outputs)
    while todo:
        k = todo.pop()
        if k in need:
            continue
        need.add(k)
        if program.ops[k] not in ("const", "t", "hsin", "hcos"):
            todo.append(program.a[k])
            if program.ops[k] in ("add", "sub", "mul", "div", "pow"):
                todo.append(program.b[k])
    return sorted(need)


def jets(program, outputs, fmt) -> tuple[list[str], dict]:
    """(C statements, node -> its jet as three C expressions) for the nodes ``outputs``
    reach; ``fmt`` prints a float as C."""
    lines, jet = [], {}
    c = program.consts

    def fmt_(value) -> str:               # a negative number parenthesised: no "--"
        text = fmt(value)
        return f"({text})" if text.startswith("-") else text
    for k in _reach(program, outputs):
        op, a, b = program.ops[k], program.a[k], program.b[k]
        v, d, dd = f"v{k}", f"d{k}", f"dd{k}"
        if op == "const":
            jet[k] = (fmt_(c[a]), "0.0", "0.0")
            continue
        if op == "t":
            jet[k] = ("t", "1.0", "0.0")
            continue
        if op in ("hsin", "hcos"):
            A, w, p = fmt_(c[a]), fmt_(c[a + 1]), fmt_(c[a + 2])
            s, co = (("sin", "cos") if op == "hsin" else ("cos", "sin"))
            sign = "" if op == "hsin" else "-"
            body = [f"const double th{k} = {w} * t + {p};",
                    f"const double {v} = {A} * {s}(th{k});",
                    f"const double {d} = {sign}{A} * {w} * {co}(th{k});",
                    f"const double {dd} = -{A} * {w} * {w} * {s}(th{k});"]
        elif op in ("add", "sub"):
            x, y, o = jet[a], jet[b], "+" if op == "add" else "-"
            body = [f"const double {n} = {p} {o} {q};" for n, p, q in zip((v, d, dd), x, y)]
        elif op == "neg":
            body = [f"const double {n} = -({p});" for n, p in zip((v, d, dd), jet[a])]
        elif op == "mul" and _constant(jet[a]) or op == "mul" and _constant(jet[b]):
            (k0, _, _), y = (jet[a], jet[b]) if _constant(jet[a]) else (jet[b], jet[a])
            body = [f"const double {n} = {k0} * {p};" for n, p in zip((v, d, dd), y)]
        elif op == "div" and _constant(jet[b]):
            body = [f"const double {n} = {p} / {jet[b][0]};" for n, p in zip((v, d, dd), jet[a])]
        elif op == "mul":
            (x0, x1, x2), (y0, y1, y2) = jet[a], jet[b]
            body = [f"const double {v} = {x0} * {y0};",
                    f"const double {d} = {x1} * {y0} + {x0} * {y1};",
                    f"const double {dd} = {x2} * {y0} + 2.0 * {x1} * {y1} + {x0} * {y2};"]
        elif op == "div":
            (x0, x1, x2), (y0, y1, y2) = jet[a], jet[b]
            body = [f"const double {v} = {x0} / {y0};",
                    f"const double {d} = ({x1} - {v} * {y1}) / {y0};",
                    f"const double {dd} = ({x2} - 2.0 * {d} * {y1} - {v} * {y2}) / {y0};"]
        elif op in ("powi", "powr"):
            (x0, x1, x2), n = jet[a], float(c[b])
            f1 = "0.0" if n == 0.0 else f"{fmt_(n)} * pow({x0}, {fmt_(n - 1.0)})"
            f2 = "0.0" if n * (n - 1.0) == 0.0 else \
                f"{fmt_(n * (n - 1.0))} * pow({x0}, {fmt_(n - 2.0)})"
            body = [f"const double {v} = pow({x0}, {fmt_(n)});",
                    f"const double {d} = {f1} * {x1};",
                    f"const double {dd} = {f2} * {x1} * {x1} + {f1} * {x2};"]
        elif op == "pow":                    # x^y = exp(y log x), x > 0
            (x0, x1, x2), (y0, y1, y2) = jet[a], jet[b]
            body = [f"const double g{k} = {y1} * log({x0}) + {y0} * {x1} / {x0};",
                    f"const double h{k} = {y2} * log({x0}) + 2.0 * {y1} * {x1} / {x0} + "
                    f"{y0} * ({x2} / {x0} - {x1} * {x1} / ({x0} * {x0}));",
                    f"const double {v} = pow({x0}, {y0});",
                    f"const double {d} = {v} * g{k};",
                    f"const double {dd} = {v} * (h{k} + g{k} * g{k});"]
        elif op in _UNARY:
            f0, f1, f2 = (e.format(x=f"x{k}", f=v) for e in _UNARY[op])
            x0, x1, x2 = jet[a]
            body = [f"const double x{k} = {x0};", f"const double {v} = {f0};",
                    f"const double {d} = ({f1}) * {x1};",
                    f"const double {dd} = ({f2}) * {x1} * {x1} + ({f1}) * {x2};"]
        else:
            raise Unsupported(op)
        lines += body
        jet[k] = (v, d, dd)
    return lines, jet


def function(law, fmt) -> list[str] | None:
    """The body of ``scene_law_jets(double t, double *u)`` (u as crt_law_at writes it), or
    None for a law with a table."""
    kind = getattr(law, "kind", "")
    if kind == "table" or (kind == "bodies" and (law.program is None
                                                 or any(o < 0 for o in law.out))):
        return None
    if kind == "bodies":
        program, outputs = law.program, list(law.out)
        slots = [law.slot(k) for k in range(len(outputs))]
    else:
        program, outputs = law, list(law.outputs)
        slots = [(k, 3) for k in range(3)]
    try:
        lines, jet = jets(program, outputs, fmt)
    except Unsupported:
        return None
    reads_t = re.compile(r"\bt\b")
    if not any(reads_t.search(e) for e in [*lines, *(e for k in outputs for e in jet[k])]):
        lines.append("(void)t;")            # a constant law: t unread
    for node, (at, step) in zip(outputs, slots):
        for i, e in enumerate(jet[node]):
            lines.append(f"u[{at + i * step}] = {e};")
    return lines

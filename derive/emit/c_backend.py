"""Standalone C from :mod:`derive.models` specifications, rendered with jinja2.

Each function gets a file ``generated/c/<name>.c`` holding

* ``carrier_<name>(...)``: the plain convenience signature (inputs ``const double *``,
  scalar inputs by value, outputs ``double *restrict``);
* ``<name>(arg, res, iw, w, mem)`` and ``<name>_work``, ``_n_in``, ``_n_out``,
  ``_sparsity_in/out``, ``_name_in/out``, ``_checkout``, ``_release``, ``_incref``,
  ``_decref``: CasADi's external-function ABI, so that ``casadi.external(name, lib)``
  loads a compiled library of them.

The header ``carrier.h`` declares all of them; a Makefile and a README complete the
folder.  Output is deterministic: no timestamps, no absolute paths, sorted inputs.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import sympy as sp

from ..models import FunctionSpec
from .c_printer import c_expression
from .program import Program, build
from .render import environment, versions

PREFIX = "carrier_"


@dataclass(frozen=True)
class CArg:
    name: str
    size: int
    labels: tuple

    @property
    def scalar(self) -> bool:
        return self.size == 1


def _names(program: Program, inputs: list[CArg], scalar_inputs_by_value: bool,
           params: tuple = ()) -> dict:
    names: dict = {sym: f"env->prm[{k}]" for k, sym in enumerate(params)}
    for vec, arg in zip(program.inputs, inputs):
        for k, sym in enumerate(vec):
            if arg.scalar and scalar_inputs_by_value:
                names[sym] = arg.name
            else:
                names[sym] = f"{arg.name}[{k}]"
    taken = {arg.name for arg in inputs}
    for sym, _ in program.steps:
        names[sym] = _identifier(sym.name, taken)
    return names


def _identifier(name: str, taken: set) -> str:
    """A C identifier for a symbol's name (``x''`` -> ``x_dd``), unique in ``taken``."""
    out = name.lstrip("_").replace("'", "_d")
    out = "".join(ch if ch.isalnum() or ch == "_" else "_" for ch in out) or "v"
    if out[0].isdigit():
        out = "v" + out
    base, k = out, 1
    while out in taken:
        out = f"{base}_{k}"
        k += 1
    taken.add(out)
    return out


def body(spec: FunctionSpec, program: Program | None = None, params: tuple = ()) -> dict:
    """The statements of a function: ``steps`` (temporaries) and ``assigned`` (one list
    of (target, C expression) per output), with inputs named by the spec (scalar inputs
    by value) and the operation count.  ``params`` are symbols read at run time from
    ``env->prm[k]`` (the runtime's parametric models)."""
    program = program or build(spec)
    inputs = [CArg(v.name, len(v.entries), v.labels) for v in spec.inputs]
    outputs = [CArg(v.name, len(v.entries), v.labels) for v in spec.outputs]
    names = _names(program, inputs, scalar_inputs_by_value=True, params=params)
    steps = [(names[sym], c_expression(expr, names)) for sym, expr in program.steps]
    assigned = []
    for arg, values in zip(outputs, program.outputs):
        assigned.append([(f"{arg.name}[{k}]", c_expression(sp.sympify(v), names))
                         for k, v in enumerate(values)])
    read = set()
    for _, expr in program.steps:
        read |= expr.free_symbols
    for values in program.outputs:
        for v in values:
            read |= sp.sympify(v).free_symbols
    unused = [arg.name for arg, vec in zip(inputs, program.inputs) if not set(vec) & read]
    return {"inputs": inputs, "outputs": outputs, "steps": steps, "assigned": assigned,
            "ops": program.ops, "n_steps": len(program.steps), "unused": unused}


def function_context(spec: FunctionSpec, program: Program | None = None) -> dict:
    return {
        "name": spec.name,
        "prefix": PREFIX,
        "doc": spec.doc,
        **body(spec, program),
        "signature": signature(spec),
    }


def signature(spec: FunctionSpec) -> str:
    ins = ", ".join(f"{v.name}[{len(v.entries)}]" for v in spec.inputs)
    outs = ", ".join(f"{v.name}[{len(v.entries)}]" for v in spec.outputs)
    return f"{spec.name}({ins}) -> ({outs})"


def render_c(specs: list[FunctionSpec], out_dir: Path, model_doc: str) -> dict[str, str]:
    """Render every file of ``generated/c`` (and the Makefile beside it) as text."""
    env = environment()
    tool_versions = versions()
    contexts = [function_context(spec) for spec in specs]
    files: dict[str, str] = {}
    tpl = env.get_template("c/function.c.jinja")
    for ctx in contexts:
        files[f"c/{ctx['name']}.c"] = tpl.render(
            **ctx, template="templates/c/function.c.jinja", versions=tool_versions)
    files["c/carrier.h"] = env.get_template("c/carrier.h.jinja").render(
        functions=contexts, prefix=PREFIX, template="templates/c/carrier.h.jinja",
        versions=tool_versions, model_doc=model_doc)
    files["c/README.md"] = env.get_template("c/README.md.jinja").render(
        functions=contexts, prefix=PREFIX, versions=tool_versions, model_doc=model_doc)
    files["Makefile"] = env.get_template("make/Makefile.jinja").render(
        sources=sorted(f"c/{ctx['name']}.c" for ctx in contexts),
        template="templates/make/Makefile.jinja", versions=tool_versions)
    return files

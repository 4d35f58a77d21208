"""Standalone C from :mod:`derive.models` specifications, rendered with jinja2.

Each function gets a file ``generated/c/<name>.c`` holding

* ``carrier_<name>(...)``: the plain convenience signature (inputs ``const double *``,
  scalar inputs by value, outputs ``double *CARRIER_RESTRICT``: ``restrict`` in C99,
  the compiler's spelling in C++);
* ``<name>(arg, res, iw, w, mem)`` and ``<name>_work``, ``_n_in``, ``_n_out``,
  ``_sparsity_in/out``, ``_name_in/out``, ``_checkout``, ``_release``, ``_incref``,
  ``_decref``: CasADi's external-function ABI, so that ``casadi.external(name, lib)``
  loads a compiled library of them.

Each function ``<name>`` also gets ``jac_<name>`` (``generated/c/jac_<name>.c``, from
:mod:`derive.jacobians`): its Jacobian blocks in CasADi's ``jac_`` convention, so that
``casadi.jacobian`` of the loaded functions, and the optimisers built on it, work; but a
function whose spec says ``jacobian=False`` (the rough plane's, whose modes switch at
events).

The header ``carrier.h`` declares all of them; a Makefile, a CMake project (with a
package config for ``find_package(carrier)``) and a README complete the folder.  Output
is deterministic: no timestamps, no absolute paths, sorted inputs.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import sympy as sp

from ..jacobians import JacobianSpec, jacobian
from ..models import FunctionSpec
from .c_printer import c_expression
from .latency import readiness
from .program import HOT, Program, build
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


def _state_loads(program: Program, inputs: list[CArg], names: dict, read: set) -> list:
    """Each entry of a fed-back input (:data:`~derive.emit.program.HOT`) that the program
    reads, loaded once into a local through a volatile lvalue.

    An integrator writes the stage state just before the call; compilers otherwise merge
    neighbouring loads of it into vector loads that straddle the caller's stores, which
    store-to-load forwarding cannot serve, so the call waits for the stores to reach the
    cache (``derive bench rhs``: 23.9 against 21.6 ns per call of the general flight RHS
    in its latency loop at -O3 -march=native).  A volatile access is one scalar load,
    which forwarding serves from any store that covers it.  Returns ``{symbol: (order,
    local, load)}``: :func:`body` places each load just before the first statement that reads
    it, so that no register holds an entry before it is needed."""
    loads = {}
    taken = set(names.values())
    for index, (vec, arg) in enumerate(zip(program.inputs, inputs)):
        if arg.name not in HOT or arg.scalar:
            continue
        for k, sym in enumerate(vec):
            if sym not in read:
                continue
            local = _identifier(sym.name, taken)
            loads[sym] = ((index, k), local, f"((const volatile double *){arg.name})[{k}]")
            names[sym] = local
    return loads


# body(spec) of each spec rendered in this process: the runtime's models share most of
# their functions (the surfaces' eight are in seven models, the momentum form's four in
# four) and generated/c renders them too; one CSE and one printing each, not up to eight
_BODIES: dict = {}


def body(spec: FunctionSpec, program: Program | None = None, params: tuple = ()) -> dict:
    """The statements of a function: ``steps`` (temporaries) and ``assigned`` (one list
    of (target, C expression) per output), with inputs named by the spec (scalar inputs
    by value) and the operation count.  ``params`` are symbols read at run time from
    ``env->prm[k]`` (the runtime's parametric models).  The state (an input named in
    :data:`~derive.emit.program.HOT`) is loaded first, entry by entry
    (:func:`_state_loads`), and sums and products are printed in the order their values
    are ready (:func:`~derive.emit.latency.readiness`).  Without a program or params the
    result is remembered by the spec object (derive's spec functions are cached, so a
    spec asked for again is the same object; it is kept with its body, so that its id is
    never another's); each call gets its own dict."""
    if program is None and not params:
        if id(spec) not in _BODIES:
            _BODIES[id(spec)] = (spec, _body(spec, build(spec), ()))
        return dict(_BODIES[id(spec)][1])
    return _body(spec, program or build(spec), params)


def _body(spec: FunctionSpec, program: Program, params: tuple) -> dict:
    inputs = [CArg(v.name, len(v.entries), v.labels) for v in spec.inputs]
    outputs = [CArg(v.name, len(v.entries), v.labels) for v in spec.outputs]
    names = _names(program, inputs, scalar_inputs_by_value=True, params=params)
    read = set()
    for _, expr in program.steps:
        read |= expr.free_symbols
    for values in program.outputs:
        for v in values:
            read |= sp.sympify(v).free_symbols
    loads = _state_loads(program, inputs, names, read)
    rank = readiness(program) if loads else None
    steps = []

    def load_for(expr):
        for sym in sorted(expr.free_symbols & loads.keys(), key=lambda s: loads[s][0]):
            steps.append(loads.pop(sym)[1:])

    for sym, expr in program.steps:
        load_for(expr)
        steps.append((names[sym], c_expression(expr, names, rank)))
    assigned = []
    for arg, values in zip(outputs, program.outputs):
        for v in values:
            load_for(sp.sympify(v))
        assigned.append([(f"{arg.name}[{k}]", c_expression(sp.sympify(v), names, rank))
                         for k, v in enumerate(values)])
    unused = [arg.name for arg, vec in zip(inputs, program.inputs) if not set(vec) & read]
    return {"inputs": inputs, "outputs": outputs, "steps": steps, "assigned": assigned,
            "ops": program.ops, "n_steps": len(program.steps), "unused": unused}


def _sparsity_text(values: tuple, indent: int = 6, width: int = 92) -> str:
    """``a, b, c`` wrapped into lines of at most ``width`` columns."""
    lines, line = [], ""
    for text in (str(v) for v in values):
        piece = text if not line else line + ", " + text
        if len(piece) + indent > width and line:
            lines.append(line + ",")
            line = text
        else:
            line = piece
    lines.append(line)
    return ("\n" + " " * indent).join(lines)


def _abi(name: str, sparsity: tuple, size: int, index: int, plain) -> dict:
    return {"name": name, "sparsity": sparsity, "sparsity_text": _sparsity_text(sparsity),
            "size": size, "index": index, "plain": plain}


def function_context(spec: FunctionSpec, program: Program | None = None,
                     jacobian: JacobianSpec | None = None) -> dict:
    """What function.c.jinja and the header need.  ``abi_inputs`` / ``abi_outputs``: the
    CasADi ABI's arguments (for a ``jac_`` function the nominal outputs and the
    identically zero blocks, which the plain function does not take)."""
    b = body(spec, program)
    if jacobian is None:
        abi_inputs = [_abi(a.name, (a.size, 1, 1), a.size, k, k)
                      for k, a in enumerate(b["inputs"])]
        abi_outputs = [_abi(a.name, (a.size, 1, 1), a.size, k, k)
                       for k, a in enumerate(b["outputs"])]
        nominal, zero_blocks, of = [], [], None
    else:
        n = len(b["inputs"])
        abi_inputs = [_abi(a.name, (a.size, 1, 1), a.size, k, k)
                      for k, a in enumerate(b["inputs"])]
        abi_inputs += [_abi(v.name, (len(v.entries), 1, 0, 0), len(v.entries), n + k, None)
                       for k, v in enumerate(jacobian.nominal)]
        plain = {a.name: k for k, a in enumerate(b["outputs"])}
        abi_outputs = [_abi(blk.name, blk.sparsity(), blk.nnz, k, plain.get(blk.name))
                       for k, blk in enumerate(jacobian.blocks)]
        # the nonzeros of a block are documented by their block, not one by one
        shapes = {blk.name: blk for blk in jacobian.blocks}
        b["outputs"] = [
            CArg(a.name, a.size, (f"d {shapes[a.name].out}/d {shapes[a.name].inp} "
                                  f"({shapes[a.name].nrow}x{shapes[a.name].ncol}), "
                                  "column-compressed nonzeros",))
            for a in b["outputs"]]
        nominal = [v.name for v in jacobian.nominal]
        zero_blocks = [blk.name for blk in jacobian.blocks if blk.name not in plain]
        of = jacobian.of.name
    return {
        "name": spec.name,
        "prefix": PREFIX,
        "doc": spec.doc,
        **b,
        "signature": signature(spec, jacobian),
        "abi_inputs": abi_inputs,
        "abi_outputs": abi_outputs,
        "nominal": nominal,
        "zero_blocks": zero_blocks,
        "jacobian_of": of,
    }


def signature(spec: FunctionSpec, jacobian: JacobianSpec | None = None) -> str:
    """``name(q[18], u[9], e) -> (I[1])``: scalar inputs are passed by value; a ``jac_``
    function lists its blocks as ``name[nonzeros of rows x columns]``."""
    ins = ", ".join(v.name if len(v.entries) == 1 else f"{v.name}[{len(v.entries)}]"
                    for v in spec.inputs)
    if jacobian is None:
        outs = ", ".join(f"{v.name}[{len(v.entries)}]" for v in spec.outputs)
    else:
        outs = ", ".join(f"{blk.name}[{blk.nnz} of {blk.nrow}x{blk.ncol}]"
                         for blk in jacobian.blocks if blk.nnz)
    return f"{spec.name}({ins}) -> ({outs})"


def _project_version(version: str) -> str:
    """CMake wants digits and dots: ``0.1.0`` stays, anything else (``absent``) is 0."""
    return version if re.fullmatch(r"\d+(\.\d+){0,3}", version) else "0"


def render_c(specs: list[FunctionSpec], out_dir: Path, model_doc: str,
             progress=None) -> dict[str, str]:
    """Render every file of ``generated/c`` (and the Makefile and CMake files beside it)
    as text: each function of ``specs`` and its ``jac_`` (derive.jacobians).
    ``progress``: told ``(done, total, name)`` after each function (its CSE and printing:
    seconds each for the largest)."""
    env = environment()
    tool_versions = versions()
    told = progress or (lambda done, total, name: None)
    total = len(specs) + sum(1 for spec in specs if spec.jacobian)
    contexts = []
    for spec in specs:
        contexts.append(function_context(spec))
        told(len(contexts), total, spec.name)
    jac_contexts = []
    for spec in specs:
        if spec.jacobian:
            j = jacobian(spec)
            jac_contexts.append(function_context(j.spec, jacobian=j))
            told(len(contexts) + len(jac_contexts), total, j.spec.name)
    files: dict[str, str] = {}
    tpl = env.get_template("c/function.c.jinja")
    for ctx in contexts + jac_contexts:
        files[f"c/{ctx['name']}.c"] = tpl.render(
            **ctx, template="templates/c/function.c.jinja", versions=tool_versions)
    files["c/carrier.h"] = env.get_template("c/carrier.h.jinja").render(
        functions=contexts, jacobians=jac_contexts, prefix=PREFIX,
        template="templates/c/carrier.h.jinja", versions=tool_versions, model_doc=model_doc)
    files["c/README.md"] = env.get_template("c/README.md.jinja").render(
        functions=contexts, jacobians=jac_contexts, prefix=PREFIX, versions=tool_versions,
        model_doc=model_doc)
    sources = sorted(f"c/{ctx['name']}.c" for ctx in contexts + jac_contexts)
    files["Makefile"] = env.get_template("make/Makefile.jinja").render(
        sources=sources, template="templates/make/Makefile.jinja", versions=tool_versions)
    files["CMakeLists.txt"] = env.get_template("cmake/CMakeLists.txt.jinja").render(
        sources=sources, template="templates/cmake/CMakeLists.txt.jinja",
        versions=tool_versions, project_version=_project_version(tool_versions["derive"]))
    files["cmake/carrierConfig.cmake"] = env.get_template(
        "cmake/carrierConfig.cmake.jinja").render(
        template="templates/cmake/carrierConfig.cmake.jinja", versions=tool_versions)
    return files

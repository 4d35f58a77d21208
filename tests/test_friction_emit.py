"""The rough plane's FunctionSpecs rendered the way ``derive emit`` renders every function.

They are not in ``generated/`` yet (derive/friction_models.py): here they are rendered
by the same C backend (each function and its ``jac_``, the header), compiled with
``-Wall -Wextra -Wpedantic -Werror`` and loaded through ctypes and
``casadi.external``, and built as CasADi functions by the CasADi backend.  At random
inputs the standalone C, the CasADi function and the NumPy evaluation of the SymPy
expressions agree to 1e-12 (about 1e-13 measured), and each ``jac_`` equals CasADi's AD
of the CasADi function (slow: the ``jac_`` take about 20 s to derive).
"""
from __future__ import annotations

import ctypes

import casadi as ca
import numpy as np
import pytest

from cases import cases
from derive import friction_models as fm
from derive.cbuild import build_shared
from derive.clib import wrap
from derive.emit.c_backend import PREFIX, function_context, render_c
from derive.emit.casadi_backend import build_function
from derive.emit.numpy_backend import compile_spec
from derive.emit.render import GENERATED, environment, versions
from derive.jacobians import jacobian
from derive.models import layout_doc

SPECS = fm.friction_specs()
TOL = 1e-12


def _render_functions() -> dict:
    """Each function's C and a header for them, without the ``jac_`` (whose symbolic
    differentiation takes about 20 s: the slow test below renders everything)."""
    env = environment()
    contexts = [function_context(spec) for spec in SPECS]
    tpl = env.get_template("c/function.c.jinja")
    files = {f"{ctx['name']}.c": tpl.render(**ctx, template="templates/c/function.c.jinja",
                                            versions=versions()) for ctx in contexts}
    files["carrier.h"] = env.get_template("c/carrier.h.jinja").render(
        functions=contexts, jacobians=[], prefix=PREFIX, template="templates/c/carrier.h.jinja",
        versions=versions(), model_doc=layout_doc())
    return files


@pytest.fixture(scope="module")
def library() -> str:
    return str(build_shared(_render_functions(), flags=("-O2",), name="libfriction"))


@pytest.fixture(scope="module")
def library_with_jac() -> str:
    files = render_c(SPECS, GENERATED, layout_doc())
    sources = {name.split("/", 1)[1]: text for name, text in files.items()
               if name.startswith("c/") and name.endswith((".c", ".h"))}
    return str(build_shared(sources, flags=("-O2",), name="libfriction"))


def inputs(spec, c, rng) -> list:
    """Random inputs of a friction function for the case ``c``."""
    from derive import darboux_keller as dk
    J_op = np.diag(c.J)
    W = np.eye(3) / (c.M + c.m) + c.A @ ne_lever(c).T @ np.linalg.solve(
        J_op + c.m * c.M / (c.m + c.M) * (c.r @ c.r * np.eye(3) - np.outer(c.r, c.r)),
        ne_lever(c)) @ c.A.T
    by_name = {"q": c.q_general, "u": c.u, "s": c.s, "p": c.p, "sdot": rng.normal(size=3),
               "mu_f": rng.uniform(0.0, 1.2, 1), "P": rng.normal(size=3),
               "W": dk.upper(W), "c": rng.uniform(0.0, 3.0, 1),
               "y": np.r_[rng.normal(size=3), rng.normal(size=4)], "w": rng.normal(size=6),
               "omega_dot": rng.normal(size=3), "R": rng.normal(size=3)}
    th = rng.uniform(-np.pi, np.pi)
    by_name["dir"] = by_name["sigma"] = np.array([np.cos(th), np.sin(th)])
    return [by_name[v.name] for v in spec.inputs]


def ne_lever(c):
    from newton_euler_friction import skew
    return skew(c.s - c.m / (c.m + c.M) * c.r)


def _casadi_call(f, values):
    return [np.array(r.full()).ravel() for r in f.call([ca.DM(v) for v in values])]


@pytest.mark.parametrize("spec", SPECS, ids=[s.name for s in SPECS])
def test_c_casadi_numpy_agree(spec, library):
    c_fn = wrap(ctypes.CDLL(library), spec)
    ref = compile_spec(spec)
    cas = build_function(spec)
    ext = ca.external(spec.name, library)
    rng = np.random.default_rng(7)
    worst = 0.0
    for c in cases(100, seed=19):
        values = inputs(spec, c, rng)
        want = ref(*values)
        for got in (c_fn(*values), _casadi_call(cas, values), _casadi_call(ext, values)):
            for a, b in zip(got, want):
                err = np.max(np.abs(np.ravel(a) - np.ravel(b))) / max(np.max(np.abs(b)), 1e-300)
                worst = max(worst, float(err))
    print(spec.name, f"{worst:.1e}")
    assert worst < TOL


def _jacobians(f: ca.Function, name: str) -> ca.Function:
    xs = [ca.MX.sym(f.name_in(j), f.sparsity_in(j)) for j in range(f.n_in())]
    outs = f.call(xs)
    return ca.Function(name, xs, [ca.jacobian(y, x) for y in outs for x in xs])


@pytest.mark.slow
@pytest.mark.parametrize("spec", SPECS, ids=[s.name for s in SPECS])
def test_jac_is_casadis_ad(spec, library_with_jac):
    ext = ca.external(spec.name, library_with_jac)
    assert ext.jacobian().name() == f"jac_{spec.name}"
    ours, theirs = _jacobians(ext, "ours"), _jacobians(build_function(spec), "theirs")
    assert len(jacobian(spec).blocks) == ours.n_out()
    rng = np.random.default_rng(11)
    for c in cases(10, seed=23):
        values = [ca.DM(v) for v in inputs(spec, c, rng)]
        for a, b in zip(ours.call(values), theirs.call(values)):
            a, b = np.array(ca.densify(a).full()), np.array(ca.densify(b).full())
            assert np.max(np.abs(a - b)) <= 1e-11 * max(1.0, np.max(np.abs(b)))

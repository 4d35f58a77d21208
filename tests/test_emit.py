"""Issue 3: the emitted functions agree with each other and with the SymPy expressions.

At 200 random states, for every function: the CasADi function loaded from
generated/casadi, the standalone C through ctypes, the same C library through
casadi.external, and a direct NumPy evaluation of the derived SymPy expressions
(numpy_backend) agree to 1e-13 relative.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
import sympy as sp

from cases import cases, inputs_for, rel_err
from derive.clib import generated_library, load_generated
from derive.emit.numpy_backend import compile_spec
from derive.emit.render import GENERATED
from derive.models import all_specs, flight_rhs, gap, impact

N_STATES = 200
TOL = 1e-13
SPECS = all_specs()


@pytest.fixture(scope="module")
def implementations():
    c_funcs = load_generated()
    lib = str(generated_library())
    out = {}
    for spec in SPECS:
        out[spec.name] = {
            "numpy": compile_spec(spec),
            "casadi": ca.Function.load(str(GENERATED / "casadi" / f"{spec.name}.casadi")),
            "c": c_funcs[spec.name],
            "external": ca.external(spec.name, lib),
        }
    return out


def _exact(term) -> bool:
    """A term computed without rounding: a number, a sign (-1, 0, 1) or their product."""
    return all(f.is_Number or isinstance(f, sp.sign) for f in sp.Mul.make_args(term))


def magnitude(expr):
    """The expression with every sum and product taken over absolute values: the scale
    against which rounding error of a sum with cancellation is measured (h, v_n).  The
    exact terms of a sum are summed as they are (a cylinder's guard 1 - sign(x^2 + y^2)
    is 0, not 2)."""
    if expr.is_Add:
        exact = [a for a in expr.args if _exact(a)]
        return sp.Add(*[magnitude(a) for a in expr.args if not _exact(a)],
                      sp.Abs(sp.Add(*exact)))
    if expr.is_Mul:
        return expr.func(*[magnitude(a) for a in expr.args])
    if expr.is_Pow:
        return sp.Pow(magnitude(expr.base), expr.exp)
    return sp.Abs(expr)


def scale_function(spec):
    """For functions without solves, the magnitude of each output; else None (the
    output vector's own max-norm is the scale)."""
    if spec.solves:
        return None
    exprs = [[magnitude(spec.inlined(v)) for v in vec.entries] for vec in spec.outputs]
    return sp.lambdify([list(v.entries) for v in spec.inputs], exprs, modules="numpy")


def _casadi_call(f, values):
    res = f.call([ca.DM(v) for v in values])
    return [np.array(r.full()).ravel() for r in res]


@pytest.mark.parametrize("spec", SPECS, ids=[s.name for s in SPECS])
def test_all_implementations_agree(spec, implementations):
    impl = implementations[spec.name]
    scale = scale_function(spec)
    rng = np.random.default_rng(3)
    worst = {"casadi": 0.0, "c": 0.0, "external": 0.0}
    for c in cases(N_STATES, seed=23):
        values = inputs_for(spec, c, rng)
        ref = impl["numpy"](*values)
        scales = scale(*values) if scale else [np.max(np.abs(r)) for r in ref]
        got = {"casadi": _casadi_call(impl["casadi"], values),
               "c": impl["c"](*values),
               "external": _casadi_call(impl["external"], values)}
        for name, outs in got.items():
            for a, b, sc in zip(outs, ref, scales):
                err = np.max(np.abs(np.ravel(a) - np.ravel(b)) / np.maximum(np.ravel(sc), 1e-300))
                worst[name] = max(worst[name], float(err))
    print(spec.name, {k: f"{v:.1e}" for k, v in worst.items()})
    assert max(worst.values()) < TOL, worst


def test_models_agree_where_they_overlap(implementations):
    for c in cases(50, seed=29):
        qg, qv = c.q_general, c.q_vertical
        (hg, vg) = implementations["general_gap"]["c"](qg, c.u, c.s, c.p)
        (hv, vv) = implementations["vertical_gap"]["c"](qv, c.u, c.s, c.p)
        assert rel_err(hv, hg) < TOL and rel_err(vv, vg) < TOL
        qpg, Ig = implementations["general_impact"]["c"](qg, c.u, c.s, c.p, c.e)
        qpv, Iv = implementations["vertical_impact"]["c"](qv, c.u, c.s, c.p, c.e)
        assert rel_err(Iv, Ig) < TOL
        assert rel_err(qpv, np.r_[qpg[2], qpg[5], qpg[6:9], qpg[15:18]]) < TOL
        (dg,) = implementations["general_flight_rhs"]["c"](qg, c.u, c.p)
        (dv,) = implementations["vertical_flight_rhs"]["c"](qv, c.u, c.p)
        (da,) = implementations["attitude_flight_rhs"]["c"](c.omega, c.u, c.p)
        assert rel_err(dv, np.r_[dg[2], dg[5], dg[6:9], dg[15:18]]) < TOL
        assert rel_err(da, dg[6:9]) < TOL


def test_impact_obeys_newton_law(implementations):
    """v_n after the map is -e v_n before (E1.13), through the generated gap function."""
    for c in cases(50, seed=31):
        q_plus, _ = implementations["general_impact"]["c"](c.q_general, c.u, c.s, c.p, c.e)
        _, v_before = implementations["general_gap"]["c"](c.q_general, c.u, c.s, c.p)
        _, v_after = implementations["general_gap"]["c"](q_plus, c.u, c.s, c.p)
        assert abs(v_after[0] + c.e * v_before[0]) < 1e-12 * max(1.0, abs(v_before[0]))


def test_specs_are_covered():
    names = {s.name for s in SPECS}
    assert {f"{m}_flight_rhs" for m in ("general", "vertical", "attitude")} <= names
    assert {"general_impact", "vertical_impact", "general_gap", "vertical_gap",
            "lowest_point_sphere", "lowest_point_ellipsoid"} <= names
    assert flight_rhs("general").name in names and gap("vertical").name in names
    assert impact("vertical").name in names


@pytest.mark.parametrize("model", ["general", "vertical", "attitude"])
def test_flight_jacobian_is_casadis_derivative(model, implementations):
    """The emitted Jacobian (differentiated symbolically, omega' through extra
    right-hand sides of the LDL^T) against CasADi's AD of the emitted flight RHS and a
    central finite difference of the standalone C RHS."""
    rhs = implementations[f"{model}_flight_rhs"]["casadi"]
    q = ca.SX.sym("q", rhs.size1_in(0))
    u, p = ca.SX.sym("u", 9), ca.SX.sym("p", 6)
    ad = ca.Function("ad", [q, u, p], [ca.jacobian(rhs(q, u, p), q)])
    c_rhs = implementations[f"{model}_flight_rhs"]["c"]
    c_jac = implementations[f"{model}_flight_jacobian"]["c"]
    rng = np.random.default_rng(5)
    for c in cases(40, seed=31):
        qv = inputs_for(flight_rhs(model), c, rng)[0]
        n = len(qv)
        (A,) = c_jac(qv, c.u, c.p)
        A = np.reshape(A, (n, n))
        want = np.array(ad(qv, c.u, c.p).full())
        assert np.max(np.abs(A - want)) < 1e-12 * max(1.0, np.max(np.abs(want)))
        h = 1e-6
        fd = np.column_stack([(c_rhs(qv + h * d, c.u, c.p)[0] - c_rhs(qv - h * d, c.u, c.p)[0])
                              / (2 * h) for d in np.eye(n)])
        assert np.max(np.abs(A - fd)) < 1e-6 * max(1.0, np.max(np.abs(want)))

"""Issue 15: derivatives of the generated C for ``casadi.external``.

The C library carries ``jac_<name>`` for every function (derive/jacobians.py: symbolic
forward differentiation of the specifications, unknowns of the J solves through more
right-hand sides of the same LDL^T).  Compared here with CasADi's own AD of the
committed ``generated/casadi/<name>.casadi`` functions:

* ``casadi.jacobian`` of every output by every input of ``casadi.external(name, lib)``
  equals ``casadi.jacobian`` of the ``.casadi`` function at random physical states;
* the structural sparsity of every block is within the one CasADi's AD finds (equal but
  for the flight Jacobians' second derivatives, where SymPy cancels more);
* CasADi really calls the C (``Function.jacobian()`` of the external is the library's
  ``jac_<name>``, not a finite-difference fallback), and Newton's method
  (``casadi.rootfinder``) converges on the loaded C as on the ``.casadi`` function.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from cases import cases, inputs_for
from derive.clib import generated_library
from derive.emit.render import GENERATED
from derive.jacobians import jacobian
from derive.models import all_specs

SPECS = all_specs()
N_STATES = 40
TOL = 1e-12


@pytest.fixture(scope="module")
def library() -> str:
    return str(generated_library())


def _jacobians(f: ca.Function, name: str) -> ca.Function:
    """Every block d out_i / d in_j of ``f`` by CasADi's MX AD, output-major."""
    xs = [ca.MX.sym(f.name_in(j), f.sparsity_in(j)) for j in range(f.n_in())]
    outs = f.call(xs)
    return ca.Function(name, xs, [ca.jacobian(y, x) for y in outs for x in xs])


@pytest.mark.parametrize("spec", SPECS, ids=[s.name for s in SPECS])
def test_external_jacobian_is_casadis_ad(spec, library):
    ext = ca.external(spec.name, library)
    ref = ca.Function.load(str(GENERATED / "casadi" / f"{spec.name}.casadi"))
    # CasADi finds the library's jac_<name> and uses it
    jac = ext.jacobian()
    assert jac.name() == f"jac_{spec.name}" and jac.class_name() == ext.class_name()
    ours, theirs = _jacobians(ext, "ours"), _jacobians(ref, "theirs")
    blocks = jacobian(spec).blocks
    for k, blk in enumerate(blocks):
        want = theirs.sparsity_out(k)
        got = ca.Sparsity.compressed(list(blk.sparsity()))
        assert jac.sparsity_out(k) == got, blk.name
        # no entry CasADi's AD finds structurally nonzero is missing; ours may be
        # sparser (flight_jacobian: second derivatives that cancel symbolically), and
        # the values below are compared densely, zeros included
        assert got.is_subset(want), (blk.name, got.nnz(), want.nnz())
    rng = np.random.default_rng(11)
    worst = 0.0
    for c in cases(N_STATES, seed=37):
        values = inputs_for(spec, c, rng)
        a, b = ours(*values), theirs(*values)
        for blk, x, y in zip(blocks, a, b):
            x, y = np.array(x.full()), np.array(y.full())
            worst = max(worst, float(np.max(np.abs(x - y), initial=0.0)
                                     / max(1.0, np.max(np.abs(y), initial=0.0))))
    print(spec.name, f"{worst:.1e}")
    assert worst < TOL


def test_newton_on_the_loaded_c(library):
    """rootfinder('newton') needs the Jacobian: find omega with a given omega' of the
    general flight (the map omega -> omega' is quadratic) on the loaded C and on the
    .casadi function; both return the omega the target was made from."""
    c = cases(1, seed=41)[0]
    q0, u, p = c.q_general, c.u, c.p
    results = []
    for f in (ca.external("general_flight_rhs", library),
              ca.Function.load(str(GENERATED / "casadi" / "general_flight_rhs.casadi"))):
        w, target = ca.MX.sym("w", 3), ca.MX.sym("target", 3)
        q = ca.vertcat(q0[:6], w, q0[9:])
        residual = ca.Function("r", [w, target], [f(q, u, p)[6:9] - target])
        solver = ca.rootfinder("solve", "newton", residual, {"abstol": 1e-14})
        want = np.array(f(q0, u, p).full()).ravel()[6:9]
        start = q0[6:9] + np.array([0.05, -0.04, 0.03])
        results.append(np.array(solver(start, want).full()).ravel())
    for omega in results:
        assert np.max(np.abs(omega - q0[6:9])) < 1e-10 * max(1.0, np.max(np.abs(q0[6:9])))

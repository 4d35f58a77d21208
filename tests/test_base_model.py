"""The base model (a body on its face) as derived in derive/base.py from the momentum
theorems in the moments' terms, against the Newton–Euler formulation of the carrier and
of each point and rotor in derive/base_reference.py, which does not use the moments: the
slip's rates, the normal force and the centre of pressure under a given friction wrench,
and the wrench the rest needs, on random systems (two points on harmonic laws, a rotor on
a tilted axis, random states and yaw), to 1e-12.  The same functions emitted as C (the
generated library, -Werror) and as CasADi agree with their NumPy evaluation."""
import numpy as np
import pytest

from base_cases import moments, parameters, random_system
from derive import base
from derive import base_reference as br
from derive import face as fc
from derive.emit.numpy_backend import compile_spec

FACES = [fc.face_on("box", (0.2, 0.15, 0.05), (0.01, -0.02, 0.03), (0, 0, 1)),
         fc.face_on("cylinder", (0.12, 0.06), (0.0, 0.01, -0.02), (0, 0, -1))]


@pytest.fixture(scope="module")
def functions():
    return {s.name: compile_spec(s) for s in base.base_specs()}


@pytest.mark.parametrize("face", FACES, ids=["box", "cylinder"])
@pytest.mark.parametrize("pressure", ["uniform", "linear"])
def test_the_moments_form_is_newton_euler(functions, face, pressure):
    rng = np.random.default_rng(7)
    for _ in range(20):
        system = random_system(rng, face, pressure=pressure)
        t = rng.uniform(0, 3)
        y = np.array([*rng.normal(size=2), rng.uniform(-3, 3), *rng.normal(size=2),
                      rng.normal() * 3])
        u, p = moments(system, t), parameters(system)
        twist, = functions["base_twist"](y)
        dy, bal = br.Integrator(system).rates(t, y)
        # the same wrench as the reference's (with linear pressure it depends on cp)
        wrench, _ = br.friction(system, system.mu, bal.N, bal.cp, twist)
        dq, N, cp = functions["base_slip"](y, u, p, face.height, wrench)
        scale = np.abs(dy).max()
        assert np.abs(dq - dy).max() <= 1e-12 * scale
        assert abs(N[0] - bal.N) <= 1e-12 * bal.N
        assert np.abs(cp - bal.cp).max() <= 1e-12 * face.size
        st = br.balance_stick(system, t)
        w_rest, N_rest, cp_rest = functions["base_stick"](u, p, face.height)
        assert np.abs(w_rest - st.wrench).max() <= 1e-12 * np.abs(st.wrench).max()
        assert abs(N_rest[0] - st.N) <= 1e-12 * st.N
        assert np.abs(cp_rest - st.cp).max() <= 1e-12 * face.size


def test_the_emitted_c_and_casadi_are_the_numpy_evaluation(functions):
    import casadi as ca

    from derive.clib import load_generated
    from derive.emit.render import GENERATED
    lib = load_generated()
    rng = np.random.default_rng(3)
    for spec in base.base_specs():
        saved = ca.Function.load(str(GENERATED / "casadi" / f"{spec.name}.casadi"))
        for _ in range(10):
            args = [rng.normal(size=len(v.entries)) for v in spec.inputs]
            if spec.name != "base_twist":      # positive masses, inertia, g, height
                k = [v.name for v in spec.inputs].index("p")
                args[k] = rng.uniform(0.1, 2.0, size=6)
                args[[v.name for v in spec.inputs].index("h")] = rng.uniform(0.01, 0.2, 1)
            ref = functions[spec.name](*args)
            got = lib[spec.name](*args)
            cas = saved(*args)
            cas = [np.array(cas).ravel()] if len(spec.outputs) == 1 else \
                [np.array(c).ravel() for c in cas]
            for r, g, c in zip(ref, got, cas):
                assert np.allclose(g, r, rtol=1e-12, atol=1e-12), spec.name
                assert np.allclose(c, r, rtol=1e-12, atol=1e-12), spec.name


def test_the_rest_needs_the_rates_of_the_internal_momenta():
    """At rest the friction is the rate of the internal linear momentum, F = s''
    (horizontal), and of the internal angular momentum about O, T_z = h_z'; N carries the
    weight and the internal vertical momentum's rate; a point held still puts cp under C."""
    wrench, N, cp = base.stick_equations()
    assert wrench == (base.SDD[0], base.SDD[1], base.HD[2])
    import sympy as sp

    from derive import notation as nt
    assert sp.expand(N - ((nt.M + nt.m) * nt.g + base.SDD[2])) == 0
    still = {s: 0 for s in (*base.SD, *base.SDD, *base.HD)}
    assert sp.simplify(cp[0].xreplace(still).xreplace({base.N_SYM: N.xreplace(still)})
                       - base.S[0] / (nt.M + nt.m)) == 0

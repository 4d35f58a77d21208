"""Floquet multipliers, their checks, and the proven cases (C2.5, C3.2) coming out right.

Each monodromy is compared with something computed another way: Euler's closed form for
a rigid body turning about a principal axis, Liouville's formula with the trace
integrated by quadrature over a stretch where det != 1, and central finite differences
of the nonlinear flow."""
from __future__ import annotations

import math

import numpy as np
import pytest

from derive.scene import SceneError, parse_scene
from derive.stability import floquet
from derive.stability.families import FAMILIES, FamilyError, member
from derive.stability.variational import Monodromy


def euler_rotation_multipliers(A: float, B: float, C: float, omega: float, T: float):
    """Rotation at rate omega about the principal axis of moment C (others A, B):
    omega-block multipliers 1, exp(+-T sqrt(omega^2 (B - C)(C - A)/(A B)))."""
    s = np.sqrt(complex(omega * omega * (B - C) * (C - A) / (A * B)))
    return np.sort_complex(np.array([1.0, np.exp(s * T), np.exp(-s * T)]))


@pytest.mark.parametrize("J", [(0.10, 0.12, 0.14), (0.10, 0.14, 0.12), (0.14, 0.10, 0.05)])
def test_frozen_point_matches_euler(J):
    """C4.1 with a = 0: the carrier with the point at O is a rigid body."""
    fam = FAMILIES["C4.1"]
    values = fam.values({"a": 0.0, "J_x": J[0], "J_y": J[1], "J_z": J[2], "omega": 1.7,
                         "W": 2.5})
    _, M = member("C4.1").monodromy(values)
    got = np.sort_complex(np.linalg.eigvals(M[2:5, 2:5]))
    want = euler_rotation_multipliers(*J, 1.7, 2 * math.pi / 2.5)
    assert np.max(np.abs(got - want)) < 1e-9
    worst, _, _ = member("C4.1").point(values)
    assert (worst > 1 + floquet.UNIT_TOL) == (min(J[:2]) < J[2] < max(J[:2]))


def test_parametric_library_equals_specialised():
    """One library with the parameters read at run time gives the monodromy of the
    library specialised to the numbers (the same equations, compiled differently)."""
    fam = FAMILIES["C4.2"]
    values = fam.values({"a": 0.2, "J_y": 0.13, "omega": 2.5})
    _, M_param = member("C4.2").monodromy(values)
    scene = parse_scene(fam.scene(values))
    _, M_num = Monodromy(scene).flow(0.0, floquet.initial_state(scene), fam.period(values))
    assert np.max(np.abs(M_param - M_num)) < 1e-11


def test_liouville_over_a_stretch_where_det_is_not_one():
    """det Phi(t) = exp(int_0^t tr A): over a third of the period J(t) != J(0), so the
    determinant is far from 1 and the check has something to bite on."""
    fam = FAMILIES["C4.3"]
    values = fam.values({"a": 0.4, "R": 0.5})
    scene = parse_scene(fam.scene(values))
    mono = Monodromy(scene)
    q0 = floquet.initial_state(scene)
    t1 = fam.period(values) / 3
    _, Phi = mono.flow(0.0, q0, t1)
    tr = floquet.TraceOfJacobian(scene)
    nodes, weights = np.polynomial.legendre.leggauss(20)
    ts = 0.5 * t1 * (nodes + 1)
    values_tr = [tr(t, mono.flow(0.0, q0, t)[0]) for t in ts]
    integral = 0.5 * t1 * float(np.dot(weights, values_tr))
    det = np.linalg.det(Phi)
    assert abs(det - 1) > 1e-2
    assert det == pytest.approx(math.exp(integral), rel=1e-9)


@pytest.mark.parametrize("case", ["C4.1", "C4.2", "C4.3"])
def test_checks_of_each_monodromy(case):
    fam = FAMILIES[case]
    scene = parse_scene(fam.scene(fam.values()))
    result = floquet.analyse(scene)
    checks = result.checks()
    assert all(c["ok"] for c in checks.values()), checks
    assert checks["finite_difference"]["value"] < 1e-6
    assert result.max_modulus == pytest.approx(1.0, abs=1e-9)


def test_c3_2_stationary_rotation_is_stable():
    """C3.2: the symmetric carrier with the point on the axis turns stably about the
    vertical axis: all multipliers on the unit circle, semisimple, and perturbed runs
    whose deviations stay in proportion to the perturbation."""
    fam = FAMILIES["C4.1"]
    scene = parse_scene(fam.scene(fam.values({"J_x": 0.1, "J_y": 0.1, "J_z": 0.14,
                                              "a": 0.3})))
    result = floquet.analyse(scene, long_periods=300)
    assert result.blocks["omega, n"]["verdict"].startswith("linearly stable")
    assert floquet.runs_verdict(result.long_runs).startswith("stay bounded")
    assert floquet.runs_verdict(result.long_runs, "_omega").startswith("stay bounded")


def test_c2_5_translational_motion_is_stable_in_omega():
    """C2.5: a point moving on a line through O (c = 0) and omega(0) = 0: stable with
    respect to omega (the orientation drifts: a perturbed omega turns the body)."""
    doc = {"name": "C2.5", "body": {"mass": 1.0, "inertia": [0.1, 0.12, 0.14],
                                    "shape": "none"},
           "point": {"mass": 0.2, "law": ["0.1*sin(2*t)", "0.05*sin(2*t)", "0"]},
           "initial": {"omega": [0.0, 0.0, 0.0]}}
    result = floquet.analyse(parse_scene(doc), long_periods=300)
    assert result.blocks["omega"]["verdict"].startswith("linearly stable")
    assert np.allclose(result.monodromy[2:5, 2:5], np.eye(3), atol=1e-9)
    assert floquet.runs_verdict(result.long_runs, "_omega").startswith("stay bounded")
    assert floquet.runs_verdict(result.long_runs).startswith("drift")


def test_unstable_rotation_grows_in_long_runs():
    """About the intermediate axis the multipliers leave the circle; a long run agrees."""
    fam = FAMILIES["C4.1"]
    values = fam.values({"J_y": 0.14, "J_z": 0.12, "a": 0.1})
    scene = parse_scene(fam.scene(values))
    result = floquet.analyse(scene)
    assert result.verdict.startswith("unstable")
    run = floquet.long_run(scene, result.period, 60, 1e-8)
    assert run["growth"] == "growing"
    # the deviation grows like max|rho|^k until it saturates
    assert run["max_deviation"] > 1e3 * run["initial"]


def test_not_periodic_is_refused_with_the_field():
    fam = FAMILIES["C4.2"]
    doc = fam.scene(fam.values())
    doc["initial"]["omega"] = [0.0, 0.0, 2.3]       # not the law's rate: no stationary rotation
    with pytest.raises(SceneError, match=r"\[initial\].*not periodic"):
        floquet.analyse(parse_scene(doc))
    doc["point"]["law"] = ["0", "0", "0.1*t"]
    with pytest.raises(SceneError, match=r"\[point\].law.*not periodic"):
        floquet.law_period(parse_scene(doc))


def test_family_values_are_checked():
    fam = FAMILIES["C4.1"]
    with pytest.raises(FamilyError, match="J_z.*exceeds"):
        fam.values({"J_z": 0.5})
    with pytest.raises(FamilyError, match="not a parameter"):
        fam.values({"x0": 0.1})
    with pytest.raises(FamilyError, match="W: must be > 0"):
        fam.values({"W": 0.0})

"""The re-planning controller rendered to C: ``controller.c`` and ``controller.h`` (from
``templates/control/``), ``ctl_qp.h`` (the QP solver, copied), ``controller_data.c``
(CasADi's code of ``qp_data``) and ``CMakeLists.txt`` (``templates/control/``, copied):
the folder ``derive control`` writes, a CMake project.
"""
from __future__ import annotations

import math
import re

import numpy as np

from .. import layout
from .problem import (DATA_NAME, QP_BUDGET, SOFT_ITERATIONS, SOFT_POWER, T_STEP_FRACTION,
                      Problem, freeze, max_qp_iter)
from .solvers import SOFTENED_TOL
from ..planner.law import BASIS

G = layout.GENERAL
CASADI_INT = "long long int"
_UNUSED = re.compile(r"(static int casadi_f\d+\(const casadi_real\*\* arg, casadi_real\*\* res, "
                     r"casadi_int\* iw, casadi_real\* w, int mem\) \{\n)")


def _num(x) -> str:
    x = float(x)
    if math.isinf(x):
        return "HUGE_VAL" if x > 0 else "-HUGE_VAL"
    if not math.isfinite(x):
        raise ValueError("a non-finite number cannot be written into the controller")
    text = repr(x)
    return text if any(c in text for c in ".en") else text + ".0"


def _chunks(values, per: int = 4) -> list:
    nums = [_num(v) for v in values]
    return [nums[i:i + per] for i in range(0, len(nums), per)]


def data_source(problem: Problem) -> str:
    """CasADi's C of qp_data, named ctl_qp_data; its helpers' unused arguments marked
    used, so that it compiles under -Wall -Wextra -Wpedantic -Werror as C99 and C++."""
    import tempfile
    from pathlib import Path
    import casadi as ca
    with tempfile.TemporaryDirectory() as tmp:
        cg = ca.CodeGenerator("controller_data.c", {"casadi_int": CASADI_INT,
                                                    "with_header": False})
        cg.add(problem.qp_data)
        cg.generate(tmp + "/")
        text = (Path(tmp) / "controller_data.c").read_text(encoding="utf-8")
    text = _UNUSED.sub(lambda m: m.group(1) + "  (void)arg; (void)res; (void)iw; (void)w; "
                       "(void)mem;\n", text)
    text = text.replace(f"void {DATA_NAME}_release(int mem) {{\n",
                        f"void {DATA_NAME}_release(int mem) {{\n  (void)mem;\n")
    return text


def render(problem: Problem, w0: np.ndarray, t0: float, t_end: float, period: float,
           iterations: int) -> dict[str, str]:
    """The folder's files: controller.c, controller.h, ctl_qp.h, controller_data.c and
    CMakeLists.txt."""
    from ..emit.render import environment, versions
    from ..paths import c_sources
    f = problem.qp_data
    ctx = {"versions": versions(), "goal": problem.goal, "n_intervals": problem.N,
           "iterations": int(iterations), "nw": problem.nw, "ng": problem.ng,
           "np": problem.np, "nq": problem.nq, "model_nq": G.nq, "land": problem.land,
           "max_qp_iter": max_qp_iter(problem), "sz_arg": f.sz_arg(), "sz_res": f.sz_res(),
           "sz_iw": f.sz_iw(), "sz_w": f.sz_w(), "casadi_int": CASADI_INT,
           "t0": _num(t0), "t_end": _num(t_end), "freeze": _num(freeze(period)),
           "period": _num(period), "n_knots": problem.N + 2,
           "keep": [str(k) for k in problem.keep],
           "basis": [[_num(v) for v in row] for row in BASIS],
           "lbx": _chunks(problem.lbx), "ubx": _chunks(problem.ubx), "w0": _chunks(w0),
           "ns": problem.ns, "z1": _chunks(problem.z1), "z2": _chunks(problem.z2),
           "softened_tol": _num(SOFTENED_TOL), "soft_power": _num(SOFT_POWER),
           "t_ref": _num(w0[-1]), "step": [_num(v) for v in problem.step],
           "t_step": _num(T_STEP_FRACTION), "has_region": problem.region_row is not None,
           "region_row": problem.region_row or 0, "region_margin": _num(problem.region_margin),
           "columns": problem.columns.names if problem.columns else ("x", "y", "z"),
           "qp_budget": QP_BUDGET, "max_sqp": max(int(iterations), SOFT_ITERATIONS)}
    env = environment()
    out = {name: env.get_template(f"control/{name}.jinja").render(**ctx)
           for name in ("controller.c", "controller.h", "CMakeLists.txt")}
    out["ctl_qp.h"] = (c_sources("control") / "ctl_qp.h").read_text(encoding="utf-8")
    out["controller_data.c"] = data_source(problem)
    return out

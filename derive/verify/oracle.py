"""What the answer should be, computed another way than the runtime computes it.

* :func:`jets`: a law tree's value and first two derivatives by forward
  differentiation in NumPy, independent of the runtime's parser and its C interpreter;
  :func:`check_laws` compares an accepted law with it over the run.
* :func:`check_run`: what any honest run satisfies: finite rows in time order, an end
  time that matches the status, X_C and Y_C uniform (the plane is smooth), A a rotation,
  the parabola of C in free flight (E1.2), S not below the plane.
* :func:`reference_run`: a hard scene's reference trajectory: flights in closed form with
  1-D root finding (:func:`derive.reference.translational_bounce`), or the runtime at
  1e-13 checked against SciPy's DOP853 at 1e-13.

Checks return problems as ``"<verdict>: <detail>"`` lines; :mod:`derive.verify.judges`
turns them into verdicts.
"""
from __future__ import annotations

import math

import numpy as np

SIZE_LIMIT = 1e3           # an accepted law keeping P within 1e3 body sizes


# ---- laws: an independent evaluator of the tree ----------------------------------------
def jets(node, t: np.ndarray):
    """(f, f', f'') of a law tree at the times t, by forward differentiation."""
    kind = node[0]
    z = np.zeros_like(t)
    if kind == "num":
        return z + node[1], z, z
    if kind == "t":
        return t.copy(), z + 1.0, z
    if kind == "pi":
        return z + math.pi, z, z
    if kind == "neg":
        a, a1, a2 = jets(node[1], t)
        return -a, -a1, -a2
    if kind == "fn":
        u, u1, u2 = jets(node[2], t)
        name = node[1]
        if name == "sin":
            f, g1, g2 = np.sin(u), np.cos(u), -np.sin(u)
        elif name == "cos":
            f, g1, g2 = np.cos(u), -np.sin(u), -np.cos(u)
        elif name == "tan":
            f = np.tan(u)
            g1 = 1 + f * f
            g2 = 2 * f * g1
        elif name == "exp":
            f = np.exp(u)
            g1 = g2 = f
        elif name == "log":
            f = np.where(u > 0, np.log(np.where(u > 0, u, 1.0)), np.nan)
            g1, g2 = 1 / u, -1 / u ** 2
        elif name == "sqrt":
            f = np.where(u >= 0, np.sqrt(np.abs(u)), np.nan)
            g1 = 0.5 / f
            g2 = -0.25 / (f * u)
        elif name == "sinh":
            f, g1, g2 = np.sinh(u), np.cosh(u), np.sinh(u)
        elif name == "cosh":
            f, g1, g2 = np.cosh(u), np.sinh(u), np.cosh(u)
        elif name == "tanh":
            f = np.tanh(u)
            g1 = 1 - f * f
            g2 = -2 * f * g1
        elif name in ("asin", "acos"):
            inside = np.abs(u) <= 1
            f = np.where(inside, np.arcsin(np.clip(u, -1, 1)), np.nan)
            s = np.sqrt(np.where(inside, 1 - u * u, np.nan))
            g1 = 1 / s
            g2 = u / s ** 3
            if name == "acos":
                f, g1, g2 = math.pi / 2 - f, -g1, -g2
        elif name == "atan":
            f = np.arctan(u)
            g1 = 1 / (1 + u * u)
            g2 = -2 * u * g1 * g1
        else:
            raise KeyError(name)
        if not (u1.any() or u2.any()):
            return f, z, z
        return f, g1 * u1, g2 * u1 * u1 + g1 * u2
    a, a1, a2 = jets(node[1], t)
    b, b1, b2 = jets(node[2], t)
    if kind == "add":
        return a + b, a1 + b1, a2 + b2
    if kind == "sub":
        return a - b, a1 - b1, a2 - b2
    if kind == "mul":
        return a * b, a1 * b + a * b1, a2 * b + 2 * a1 * b1 + a * b2
    if kind == "div":
        q = a / b
        q1 = (a1 - q * b1) / b
        q2 = (a2 - 2 * q1 * b1 - q * b2) / b
        return q, q1, q2
    if kind in ("pow", "hat"):
        if node[2][0] == "num" or (b1 == 0).all() and (b2 == 0).all():
            c = b
            ci = np.round(c)
            integer = (np.abs(c - ci) < 1e-12).all()
            if integer:
                f = a ** c
                g1 = c * a ** (c - 1)
                g2 = c * (c - 1) * a ** (c - 2)
            else:
                ok = a > 0
                f = np.where(ok, np.abs(a) ** c, np.where(a == 0, 0.0, np.nan))
                g1 = np.where(ok, c * np.abs(a) ** (c - 1), np.where(a == 0, np.inf, np.nan))
                g2 = np.where(ok, c * (c - 1) * np.abs(a) ** (c - 2),
                              np.where(a == 0, np.inf, np.nan))
            if not (a1.any() or a2.any()):
                return f, z, z
            return f, g1 * a1, g2 * a1 * a1 + g1 * a2
        # a ** b = exp(b log a)
        la = jets(("fn", "log", node[1]), t)
        lb = _mul_jets(la, (b, b1, b2))
        e = np.exp(lb[0])
        return e, e * lb[1], e * (lb[2] + lb[1] ** 2)
    raise KeyError(kind)


def _mul_jets(a, b):
    return a[0] * b[0], a[1] * b[0] + a[0] * b[1], a[2] * b[0] + 2 * a[1] * b[1] + a[0] * b[2]


def check_laws(scene, laws: dict, window, size) -> list:
    """Values and derivatives of the accepted law against :func:`jets` of its tree."""
    t0, t1 = window
    t = np.concatenate([np.linspace(t0, t1, 20001),
                        np.random.default_rng(0).uniform(t0, t1, 200)])
    problems = []
    with np.errstate(all="ignore"):
        try:
            got = np.asarray(scene.law.jets(t))
        except Exception as exc:
            return [f"law.jets failed: {exc!r}"]
        for k, tree in laws.items():
            mine = jets(tree, t)
            for d in range(3):
                want = np.broadcast_to(mine[d], t.shape)
                if not np.isfinite(want).all():
                    i = int(np.argmin(np.isfinite(want)))
                    problems.append(f"silent-accept: law[{k}] derivative {d} is not finite "
                                    f"at t = {t[i]:.9g} ({want[i]})")
                    break
                if d == 0 and np.abs(want).max() > SIZE_LIMIT * size:
                    problems.append(f"silent-accept: |law[{k}]| reaches "
                                    f"{np.abs(want).max():.3g} (body size {size})")
                    break
                g = got[3 * k + d]
                scale = max(1.0, float(np.abs(want).max()))
                err = float(np.abs(g - want).max())
                if not err <= 1e-7 * scale:
                    i = int(np.nanargmax(np.abs(g - want))) if np.isfinite(err) else 0
                    problems.append(f"wrong-answer: law[{k}] derivative {d} differs from the "
                                    f"expression by {err:.3g} at t = {t[i]:.9g} "
                                    f"(runtime {g[i]:.9g}, expression {want[i]:.9g})")
                    break
    return problems


def check_run(result, job) -> list:
    """What any honest run satisfies: finite rows, an end time that matches the status,
    X_C and Y_C uniform (the plane is smooth), A a rotation, S not below the plane."""
    problems = []
    scene = result.scene
    t = np.asarray(result.t)
    q = np.asarray(result.model_q)
    if len(t) == 0:
        return ["wrong-answer: no rows"]
    if not (np.isfinite(t).all() and np.isfinite(q).all()):
        problems.append(f"wrong-answer: non-finite rows (status {result.status})")
        return problems
    if result.status == "nonfinite":
        problems.append("silent-accept: an accepted scene ends nonfinite")
    t_end = scene.t0 + scene.duration
    if result.status == "done" and abs(t[-1] - t_end) > 1e-9 * max(1.0, abs(t_end)):
        problems.append(f"wrong-answer: says done but ends at t = {t[-1]!r}")
    if np.any(np.diff(t) < 0):
        problems.append("wrong-answer: rows not in time order")
    ev = result.event_rows
    if result.status == "max_events" and len(ev) < min(scene.max_events, 1e9):
        problems.append(f"wrong-answer: max_events after {len(ev)} events "
                        f"(max_events = {scene.max_events!r})")
    if result.status == "max_steps" and result.stats.get("steps", 0) < \
            min(scene.max_steps, 1e12) - 1:
        problems.append(f"wrong-answer: max_steps after {result.stats.get('steps')} steps "
                        f"(max_steps = {scene.max_steps!r})")
    g = result.general
    if g is not None and len(g):
        g = np.asarray(g)
        x0, v0 = np.asarray(scene.com, float), np.asarray(scene.com_velocity, float)
        for i in (0, 1):
            want = x0[i] + v0[i] * (t - scene.t0)
            err = np.abs(g[:, i] - want)
            tol = 1e-6 * (1 + np.abs(want))
            if (err > tol).any():
                k = int(np.argmax(err - tol))
                problems.append(f"wrong-answer: {'XY'[i]}_C = {g[k, i]:.6g} at t = "
                                f"{t[k]:.6g}, the uniform motion gives {want[k]:.6g}")
                break
        A = g[:, 9:18].reshape(-1, 3, 3)
        err = np.abs(np.einsum("nij,nkj->nik", A, A) - np.eye(3)).max(axis=(1, 2))
        tight = scene.method != "rk4" and scene.rtol <= 1e-6 and scene.atol <= 1e-6
        if tight and (err > 1e-4).any() or (err > 0.1).any():
            k = int(np.argmax(err))
            problems.append(f"wrong-answer: A A^T - 1 = {err[k]:.3g} at t = {t[k]:.6g} "
                            f"(a_ij = {A[k].ravel().min():.3g} .. {A[k].ravel().max():.3g})")
        if not scene.contact_possible and result.status == "done":
            z = scene.com[2] + scene.com_velocity[2] * (t - scene.t0) - \
                0.5 * scene.g * (t - scene.t0) ** 2
            err = np.abs(g[:, 2] - z)
            if (err > 1e-6 * (1 + np.abs(z))).any():
                k = int(np.argmax(err))
                problems.append(f"wrong-answer: free flight Z_C = {g[k, 2]:.6g} at t = "
                                f"{t[k]:.6g}, the parabola gives {z[k]:.6g}")
    if scene.contact_possible and result.height is not None:
        h = np.asarray(result.height)
        size = job.get("size") or 1.0
        if h.size and h.min() < -1e-6 * size:
            k = int(np.argmin(h))
            problems.append(f"wrong-answer: S at {h[k]:.3g} below the plane at t = {t[k]:.6g}")
    return problems


# ---- the reference of a hard scene ------------------------------------------------------
def reference_run(doc: dict, kind: str):
    """The reference :class:`~derive.bench.routes.Run` of a hard scene on the runtime's
    output grid: ``kind`` "translational" (closed-form flights) or "numerical" (the
    runtime at 1e-13, its distance to SciPy's DOP853 at 1e-13 in ``extra["scipy_check"]``)."""
    from .. import reference
    from ..bench.routes import Run, Runtime, Scipy, errors
    from ..scene import parse_scene
    probe = Runtime(doc, "dopri5", 1e-8)           # for the grid
    grid = probe.grid
    if kind == "translational":
        states, impacts, _ = reference.translational_bounce(parse_scene(doc), grid)
        return Run(states, impacts, 0, "done")
    ref = Runtime(doc, "dop853", 1e-13).result()
    check = Scipy(doc, "DOP853", 1e-13).result()
    err, _ = errors(check, ref)
    ref.extra["scipy_check"] = err
    return ref

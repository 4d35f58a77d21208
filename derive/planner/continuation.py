"""The first solve of a task, with a continuation in the acceleration bound.

The bound on |OP''| is what keeps IPOPT's first iterates sane: lifted, or set far above
what the plan needs (``max_acceleration = 1e6``), the early steps swing the control points
far out and IPOPT may not come back within max_iterations, although the same task with a
tight bound solves in a few dozen iterations.  So a loose bound is approached from a
working bound that depends on the start, not on ``max_acceleration``:

* the working bound ``A0`` is :data:`WORKING` times the largest |OP''| of the start;
* ``max_acceleration <= RAISE A0`` (a bound near what the plan may need): one solve, as
  the task says;
* otherwise the task is solved with the bound at ``A0``; while the bound is active in the
  solution, it is raised by :data:`RAISE` and the task solved again, warm-started (primal
  and dual) from the last solution, up to ``max_acceleration``; once it is inactive the
  solution is one of the task too (a last run with the task's bound, warm, confirms it in
  an iteration or two);
* a stage that fails is tried again with a shorter raise (the square root of the last,
  down to :data:`MIN_RAISE`) from the last solution; when even that fails, the last
  stage's plan, feasible for the task (its bound is the tighter), is kept and said to be
  optimal up to its bound; a first stage that fails is tried again with half the
  working bound (twice); when that fails too, the continuation ends: the diagnosis
  (:mod:`derive.planner.diagnose`) takes over from there, and finds a task that is
  feasible after all (then solved from the plan it finds).

A looser bound thus starts from the solution of a tighter one, and each stage from a
point feasible for it: the effort does not increase along the stages, and two tasks that
differ only in a loose bound go through the same stages below both bounds.
"""
from __future__ import annotations

WORKING = 2.0       # the working bound: this times the guess's largest |OP''|
RAISE = 4.0         # a bound active in a stage's solution is raised by this factor
RAISES = 6          # at most this many raises towards a lifted bound (inf)
SHORTER = 3         # a stage that fails is tried again with the square root of the raise,
MIN_RAISE = 1.2     # down to this raise; then the last stage's plan is kept
TIGHTER = 2         # a first stage that fails is tried again with half its bound, twice


def solve_with_continuation(session) -> list:
    """[(NLPResult, stage label)] of the runs that lead to the first solution of the
    task; the last one is the task's own (its bound), unless a stage failed."""
    return approach(session, session.limits, session.run, session.w_guess, session.label)


def approach(session, limits, run, w0, label: str) -> list:
    """Runs of ``run(w0, limits, lam=, label=)`` that reach ``limits`` with the
    acceleration bound approached from the working bound of the start ``w0``."""
    tr = session.tr
    amax = limits.max_acceleration
    working = WORKING * tr.limit_values(w0)["max_acceleration"]
    if not amax > RAISE * working > 0:
        return [(run(w0, limits, label=label), "")]
    runs, bound, start, prev = [], working, None, None
    raise_by, tighter = RAISE, 0
    for _ in range(RAISES + SHORTER + TIGHTER + 1):
        res = run(start.w if start else w0, limits.replace(max_acceleration=bound),
                  lam=(start.lam_g, start.lam_x) if start else None,
                  label=f"{label} (max_acceleration {bound:.4g})")
        stage = (f"max_acceleration {bound:.6g} (continuation to {amax:.6g})" if start or
                 not tighter else
                 f"max_acceleration {bound:.6g} (the first stage of a continuation to "
                 f"{amax:.6g}: the working bound {working:.6g} halved "
                 f"{'once' if tighter == 1 else f'{tighter} times'}, as the stage above "
                 f"did not converge)")
        runs.append((res, stage))
        if not res.success and start is None and tighter < TIGHTER:
            tighter += 1                        # the first stage: a tighter working bound
            bound /= 2.0
            continue
        if not res.success:
            if start is None or raise_by <= MIN_RAISE:
                if start is not None:           # the last stage's plan is the task's too
                    runs.append((start, f"max_acceleration {prev:.6g}: kept (the stage "
                                        f"above it stopped; a plan of the task, optimal "
                                        f"with |OP''| <= {prev:.6g})"))
                return runs
            raise_by = raise_by ** 0.5          # a shorter raise from the last solution
            bound = min(amax, raise_by * prev)
            continue
        if bound >= amax:
            return runs
        start, prev = res, bound
        if tr.limit_values(res.w)["max_acceleration"] < bound * (1 - 1e-6):
            break                               # inactive: a solution of the task too
        bound = min(amax, raise_by * bound)
    runs.append((run(start.w, limits, lam=(start.lam_g, start.lam_x), label=label), ""))
    return runs

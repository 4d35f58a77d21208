"""Which of the task's limits blocks a task that IPOPT could not solve, and what the
plan would need.

IPOPT's failure says little by itself: it stops at a point of least infeasibility, or
after max_iterations wherever it is.  The first version of this report lifted each limit
in turn (removed it from the NLP) and solved again from the guess: a problem no easier
than the one that failed (without the acceleration bound IPOPT's iterates run off), read
"did not converge" as "this limit does not help", and ended "the goal itself is out of
reach" with no evidence.  The diagnosis now works by continuation from relaxed plans, in
the task's one IPOPT instance (no NLP is built again), every run with a cap on its
iterations:

0. a solve stopped near a solution (violations below :data:`NEAR`) without evidence of
   infeasibility (at max_iterations, say) is resumed from where it stopped, its barrier
   started afresh: it often converges then, and the task is solved;
1. the limits are raised, not removed (the region and the horizon by :data:`RAISE`, the
   acceleration bound to the working bound of :mod:`derive.planner.continuation`), and
   raised again while one is active in the solution; the run starts from where IPOPT
   stopped if it detected infeasibility there (the dynamics hold at such a point), else
   from the guess (the other one, then the acceleration bound at its own value, if it
   does not converge);
2. that plan asks each limit for a value (:meth:`Transcription.limit_values`: the largest
   |OP''| at the knots, the largest distance of a control point from the region's
   centre, T: the quantities the NLP bounds, so that a region of the radius reported is
   enough); the limits it exceeds are the ones that bind.  Exceeding none, the task is
   feasible, solved from that plan;
3. for each binding limit (the largest relative excess first) the others are set back to
   their values, directly, else in geometric steps from that plan (:data:`STEP`, halved
   once when a step does not converge), this one raised.  Reaching them, this limit
   blocks the task and the plan reached says what it needs; else it does not block it
   alone, and the report says how far the others came.  When IPOPT gave no evidence of
   infeasibility and the plan needs less than :data:`CLOSE` times the limit, the
   blocking limit is also brought back towards its own value: the task may turn out
   feasible (then solved), else the report adds the smallest value a plan was found
   with.

The whole diagnosis has a budget of :data:`BUDGET` IPOPT iterations; what it could not
examine within it is reported as such.

If the run with every limit raised is infeasible too, the goal itself is out of reach;
if IPOPT does not converge on it, the report says so and claims nothing.  What a plan
"needs" is that of the plan found (the effort-optimal one with the limit lifted), not a
proven minimum: IPOPT finds local optima.
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from .continuation import RAISE, RAISES, WORKING
from .transcribe import LIMITS, Limits

CAP_COLD = 150         # iterations of the run from the guess with every limit lifted
CAP_STEP = 60          # iterations of a continuation step, warm-started
STEP = 0.7             # a step moves a limit by at most this factor
HALVINGS = 1           # a failed step is retried this many times, halved
BUDGET = 400           # iterations of the whole diagnosis (a few seconds)
# what a user can do when no limit is found to blame (a new user changed five things at once)
UNDIAGNOSED = (". No limit is shown to block the task: what is hard may be the task itself "
               "(the start's spin and tilt, the height of the drop, the target); change one "
               "of those at a time, or raise a limit by hand and plan again")
CLOSE = 2.0            # a blocking limit within this factor is brought back to its value
NEAR = 1e-3            # a solve stopped with violations below this is resumed
INFEASIBLE = ("Infeasible_Problem_Detected", "Restoration_Failed")


def quantity(name: str, value: float) -> str:
    return {"max_acceleration": f"|OP''| up to {value:.4g} m/s^2",
            "region": f"a region of radius {value:.4g} m",
            "horizon": f"{value:.4g} s"}[name]


def limit_text(name: str, value: float) -> str:
    return {"max_acceleration": f"limit {value:.4g}",
            "region": f"radius {value:.4g} m",
            "horizon": f"horizon {value:.4g} s"}[name]


def blocks_text(name: str, need: float, limit: float) -> str:
    verb = "takes" if name == "horizon" else "needs"
    return f"the plan {verb} {quantity(name, need)} ({limit_text(name, limit)})"


@dataclass
class Finding:
    limit: str
    verdict: str                    # blocks | not alone | undetermined
    value: float                    # the task's value of the limit
    needed: float | None = None     # what the plan needs, if it blocks
    smallest: float | None = None   # the smallest value a plan was found with
    reached: dict = field(default_factory=dict)    # not alone: how far the others came
    text: str = ""
    plan_needs: dict = field(default_factory=dict)  # blocks: what its plan asks of each limit


@dataclass
class Diagnosis:
    limit: str | None               # the first limit that blocks (None: none found)
    needed: float | None
    message: str
    findings: list = field(default_factory=list)
    solution: object = None         # an NLPResult of the task itself, if it is feasible
    feasible: bool = False          # shown feasible (a plan keeps every limit)
    runs: int = 0
    iterations: int = 0
    seconds: float = 0.0

    def to_dict(self) -> dict:
        """plan.json's ``blocking``: limit, needed, message (as before), and the findings
        of every limit tried, the runs and the time they took."""
        return {"limit": self.limit, "needed": self.needed, "message": self.message,
                "findings": [asdict(f) for f in self.findings], "runs": self.runs,
                "iterations": self.iterations, "seconds": self.seconds}


def candidates(tr) -> list[str]:
    """The limits a task has that can be lifted: the acceleration bound; the region
    (not a circle: there it is the path); the horizon when it bounds a free T.  A task
    of several bodies has the first two when it decides a point (its rotors' bounds are
    not examined)."""
    names = []
    if not tr.bodies or tr.channels.point_channels:
        names.append("max_acceleration")
        if tr.kind == "cartesian":
            names.append("region")
    if tr.free_T and tr.task.horizon is not None:
        names.append("horizon")
    return [n for n in LIMITS if n in names]


class Spent(Exception):
    """The diagnosis's budget of iterations is spent."""


class _Runner:
    """The session's runs, counted, within the budget of :data:`BUDGET` iterations
    (the run that solves a task found feasible is not counted against it)."""

    def __init__(self, session):
        self.session = session
        self.runs, self.iterations = 0, 0

    def __call__(self, w0, limits: Limits, lam=None, cap: float = CAP_STEP, label="",
                 budget: bool = True):
        left = BUDGET - self.iterations
        if budget and left <= 0:
            raise Spent
        res = self.session.run(w0, limits, lam=lam, cap=min(cap, left) if budget else cap,
                               label=f"{self.session.label} ({label})")
        self.runs += 1
        self.iterations += res.iterations
        return res


def diagnose(session, failed) -> Diagnosis:
    """The diagnosis of a task whose solve ``failed`` (an NLPResult)."""
    t0 = time.perf_counter()
    run = _Runner(session)
    out = _diagnose(session, run, failed)
    out.runs, out.iterations, out.seconds = run.runs, run.iterations, time.perf_counter() - t0
    return out


def _diagnose(session, run, failed) -> Diagnosis:
    tr, limits = session.tr, session.limits
    if (failed.status not in INFEASIBLE and failed.extra["limits"] == limits
            and violation(failed) <= NEAR):
        # stopped near a solution without evidence of infeasibility (at max_iterations,
        # say): IPOPT resumed from there, its barrier started afresh, often converges
        res = run(failed.w, limits, cap=CAP_COLD, label="resumed")
        if res.success:
            return Diagnosis(None, None, "the task is feasible: IPOPT, resumed from where it "
                                         "stopped, converged", solution=res)
    names = candidates(tr)
    if not names:
        return Diagnosis(None, None, "not diagnosed: the task has no limit that the "
                                     "diagnosis raises (the rotors' bounds are not examined)")
    listed = ", ".join(names)
    # every limit raised by RAISE, the acceleration bound set at the working bound of a
    # solve (a lifted bound lets IPOPT's iterates run off, as in a solve)
    raised = {n: RAISE * limits.value(n) for n in names}
    if "max_acceleration" in raised:
        raised["max_acceleration"] = WORKING * tr.limit_values(
            session.w_guess)["max_acceleration"]
    # from the point where IPOPT stopped if it found the task infeasible (a point of
    # least infeasibility: the dynamics hold there), else from the guess; the other one
    # if that does not converge
    # if neither converges, once more from the guess with the acceleration bound at its
    # own value (runs near a loose bound are erratic: see continuation.py)
    starts = [failed.w, session.w_guess]
    if failed.status not in INFEASIBLE:
        starts.reverse()
    tries = [(w, raised) for w in starts]
    if "max_acceleration" in raised:
        tries.append((session.w_guess, {**raised,
                                        "max_acceleration": limits.max_acceleration}))
    try:
        for start, values in tries:
            free, raised_to = _raise(session, run, start, None, limits, values, names,
                                     cap=CAP_COLD, label=f"{listed} raised")
            if usable(free):
                break
    except Spent:
        return Diagnosis(None, None, f"not diagnosed: IPOPT did not converge with {listed} "
                                     f"raised within {BUDGET} iterations{UNDIAGNOSED}")
    raised = raised_to
    if not usable(free):
        if free.status in INFEASIBLE:
            return Diagnosis(None, None, f"the goal itself is out of reach: infeasible even "
                                         f"with {listed} raised "
                                         f"({_values(raised)})")
        why = ("stopped at its cap of iterations" if free.status == "User_Requested_Stop"
               else free.status)
        return Diagnosis(None, None, f"not diagnosed: IPOPT did not converge with {listed} "
                                     f"raised ({_values(raised)}; {why}){UNDIAGNOSED}")
    need = tr.limit_values(free.w)
    # the limit exceeded most first: to see whether it alone blocks the task, the
    # others (exceeded less) are set back to their values, the cheaper test
    binding = sorted((n for n in names if need[n] > limits.value(n) * (1 + 1e-6)),
                     key=lambda n: -need[n] / limits.value(n))
    if not binding:
        return _feasible(session, run, free, "the plan with the limits raised keeps them all")
    # IPOPT's "infeasible problem detected" is evidence that the task is infeasible;
    # a solve stopped otherwise is not, and the binding limit is then brought back to
    # its value by continuation too, which may find the task feasible after all
    evidence = failed.status in INFEASIBLE
    findings = []
    for n in binding:
        try:
            found = _examine(session, run, n, binding, limits, need, raised, free, start,
                             evidence)
        except Spent:
            findings.append(_unexamined(n, limits.value(n), findings))
            continue
        if isinstance(found, Diagnosis):
            return found
        findings.append(found)
    if not any(f.verdict == "blocks" for f in findings):
        together = " and ".join(quantity(n, need[n]) for n in binding)
        findings.append(Finding(", ".join(binding), "blocks together", math.nan, None,
                                text=f"no single limit unblocks it; with {listed} raised "
                                     f"the plan needs {together}"))
    return _report(findings)


def _unexamined(n: str, value: float, findings: list) -> Finding:
    """The finding of a limit the budget left unexamined; what is known of it: whether
    the plan of a limit found to block keeps it (then raising that one alone suffices)."""
    spent = f"the diagnosis's {BUDGET} iterations are spent"
    for f in findings:
        kept = f.plan_needs.get(n) if f.verdict == "blocks" else None
        if kept is not None and kept <= value * (1 + 1e-6):
            return Finding(n, "not examined", value,
                           text=f"raising {f.limit} alone unblocks it: that plan keeps "
                                f"{n} ({quantity(n, kept)}, {limit_text(n, value)}); "
                                f"whether raising {n} alone would also unblock it was not "
                                f"examined ({spent})")
    return Finding(n, "not examined", value, text=f"{n} not examined ({spent})")


def _examine(session, run, n, binding, limits, need, raised, free, start, evidence):
    """What the binding limit ``n`` does: a Finding, or a Diagnosis if the task turns
    out feasible."""
    tr = session.tr
    others = [m for m in binding if m != n]
    res = free
    if others:
        # directly: the others at their values, n raised (further while active),
        # from the start of the raised run; failing that, by continuation from it
        res, _ = _raise(session, run, start, None, limits, {n: raised[n]}, [n],
                        cap=CAP_COLD, label=f"{n} raised")
        reached = {m: limits.value(m) for m in others}
        if not usable(res):
            res, reached = _continue(session, run, free, limits, others,
                                     {m: need[m] for m in others}, {n: raised[n]})
        if res is None:
            far = ", ".join(f"{m} to {reached[m]:.4g} (asked {limits.value(m):.4g})"
                            for m in others)
            return Finding(n, "not alone", limits.value(n), reached=reached,
                           text=f"{n} alone does not unblock it: with {n} lifted the "
                                f"continuation brought {far}")
    got = tr.limit_values(res.w)[n]
    if got <= limits.value(n) * (1 + 1e-6):
        return _feasible(session, run, res, f"with {n} lifted the plan keeps it")
    text, smallest = blocks_text(n, got, limits.value(n)), None
    if not evidence and got <= CLOSE * limits.value(n):
        back, reached = _continue(session, run, res, limits, [n], {n: got}, {})
        if back is not None:
            return _feasible(session, run, back, f"{n} brought back to its value")
        smallest = reached[n]
        if smallest < got * (1 - 1e-3):
            text += f"; IPOPT found plans down to {quantity(n, smallest)}"
    return Finding(n, "blocks", limits.value(n), got, smallest=smallest, text=text,
                   plan_needs=dict(tr.limit_values(res.w)))


def violation(res) -> float:
    """The largest constraint violation of a run's last point (its own bounds)."""
    lbg, ubg = res.extra["bounds"]
    g = res.extra["g"]
    return float(np.max(np.maximum(np.maximum(lbg - g, g - ubg), 0.0)))


def usable(res) -> bool:
    """A run that converged, or that was stopped at its cap at a feasible point (to
    1e-6): its plan then proves what the limits it was given allow."""
    if res.success:
        return True
    return res.status == "User_Requested_Stop" and violation(res) <= 1e-6


def _values(values: dict) -> str:
    return ", ".join(f"{n} {v:.4g}" for n, v in values.items())


def _raise(session, run, w0, lam, limits: Limits, raised: dict, names, cap, label):
    """Solve with the limits ``names`` at their ``raised`` values (the others at
    ``limits``); while one of them is active in the solution, raise it by RAISE and
    solve again, warm: (the last result, the values reached)."""
    tr = session.tr
    raised = dict(raised)
    res = run(w0, limits.replace(**raised), lam=lam, cap=cap, label=label)
    for _ in range(RAISES):
        if not usable(res):
            break
        got = tr.limit_values(res.w)
        active = [n for n in names if got[n] >= raised[n] * (1 - 1e-6)]
        if not active:
            break
        raised.update({n: RAISE * raised[n] for n in active})
        res = run(res.w, limits.replace(**raised), lam=(res.lam_g, res.lam_x), cap=CAP_STEP,
                  label=label)
    return res, raised


def _report(findings: list) -> Diagnosis:
    blocking = [f for f in findings if f.verdict == "blocks"]
    parts = []
    for k, f in enumerate(blocking):
        parts.append(f"{f.limit} blocks it{' too' if k else ''}: {f.text}")
    parts += [f.text for f in findings if f.verdict != "blocks"]
    first = blocking[0] if blocking else None
    return Diagnosis(first.limit if first else None, first.needed if first else None,
                     "; ".join(parts), findings)


def _feasible(session, run, start, why: str) -> Diagnosis:
    """The task is feasible: solve it from the plan found (warm), to its own tolerance."""
    res = run(start.w, session.limits, lam=(start.lam_g, start.lam_x),
              cap=session.task.max_iterations, label="restart", budget=False)
    if res.success:
        return Diagnosis(None, None, f"the task is feasible ({why}): solved again from "
                                     "that plan", solution=res)
    return Diagnosis(None, None, f"the task is feasible ({why}), but IPOPT did not converge "
                                 f"from that plan either ({res.status})", feasible=True)


def _continue(session, run, start, limits: Limits, moving: list, need0: dict, raised: dict):
    """Bring the limits ``moving`` from the values ``start`` needs back to their own in
    geometric steps (halved, up to HALVINGS times, when a step does not converge), the
    limits ``raised`` held at their raised values (raised further while active): (the
    final result or None, the values the moving limits reached)."""
    target = {m: limits.value(m) for m in moving}
    levels = [math.log(need0[m] / target[m]) / math.log(1 / STEP) for m in moving]
    ds = 1.0 / max(1, math.ceil(max(levels)))
    s, res, halvings = 0.0, start, 0
    reached = dict(need0)
    label = ", ".join(moving) + " brought back"
    while s < 1.0:
        s_next = min(1.0, s + ds)
        values = {m: need0[m] ** (1 - s_next) * target[m] ** s_next for m in moving}
        step, up = _raise(session, run, res.w, None, limits.replace(**values), raised,
                          list(raised), cap=CAP_STEP, label=label)
        if usable(step):
            s, res, reached, raised = s_next, step, values, up
            continue
        halvings += 1
        if halvings > HALVINGS:
            return None, reached
        ds *= 0.5
    return res, reached

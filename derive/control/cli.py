"""``derive control TASK.toml -o DIR``: the command line of the closed loop.

``add_parser(subparsers)`` adds the subcommand; ``run(args)`` returns the exit status,
as derive/docs/control.md states it (0 the closed loop met its goal; 1 it ran and missed
it, or stopped before its end, said in words and in control.json's ``goal_met`` and
``status``, its outputs written, or the loop could not be closed: the offline plan
failed, as ``derive simulate`` exits 1 for a run that did not end as asked) and raises
:class:`~derive.scene.SceneError` for bad input (exit status 2 in the CLI: one line
naming the field and the rule, nothing written).
"""
from __future__ import annotations

import math
import sys


def add_parser(subparsers):
    p = subparsers.add_parser(
        "control", help="close the loop around a planned task on a disturbed plant "
                        "(re-planning in flight as generated C; per-hop feedback)")
    p.add_argument("task", help="task TOML: a plan task ([plan]) with [control] and "
                                "[disturbance]")
    p.add_argument("-o", "--output", default="control-out",
                   help="output folder (default: control-out)")
    p.add_argument("--no-animation", action="store_true", help="skip motion.gif")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress line per IPOPT iteration of the offline plan")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from .core import control, load_control_task
    task = load_control_task(args.task)        # SceneError: bad input, nothing written
    try:
        result = control(task, progress=not args.quiet)
    except RuntimeError as exc:
        from .core import ControlError
        if not isinstance(exc, ControlError):
            raise
        print(f"derive control: {exc}", file=sys.stderr)
        return 1
    written = result.write(args.output, animation=not args.no_animation)
    for line in report_lines(result):
        print(line)
    print(f"  wrote {', '.join(p.name for p in written)} to {args.output}")
    closed = result.summary.get("closed_loop", {})
    return 0 if closed.get("goal_met", True) else 1


def _achieved(task, m: dict) -> str:
    from ..planner.goals import goal_of
    return goal_of(task).achieved_text(m)


def _goal_words(m: dict) -> str:
    """Whether a loop met its goal, in words (control.json's goal_met)."""
    if "goal_met" not in m:
        return ""
    tol = m.get("goal_tolerance", {})
    if "attitude_error_rad" in m:
        err = f"{math.degrees(m['attitude_error_rad']):.3g} deg from the target attitude"
    elif "d_norm" in m:
        err = f"|d| = {m['d_norm']:.3g} m (tolerance {tol.get('d_norm', 0.0):.3g} m)"
    else:
        err = m.get("error", "no touchdown")
    word = "goal met" if m["goal_met"] else "goal NOT met"
    return f"{word}: {err} (asked: within {tol.get('degrees', 0):g} deg)"


def _failure_lines(s: dict) -> list[str]:
    """The samples whose solver failed, named for the solver that ran."""
    ctl = s.get("controller") or {}
    calls, out = ctl.get("calls", "?"), []
    if ctl.get("qp_failures"):
        out.append(f"  {ctl['qp_failures']} of {calls} calls: the QP had no solution within "
                   "its iteration limit (the law in use went on)")
    if ctl.get("ipopt_failures"):
        out.append(f"  {ctl['ipopt_failures']} of {calls} calls: IPOPT did not converge (the "
                   "law in use went on)")
    if ctl.get("softened"):
        out.append(f"  {ctl['softened']} of {ctl.get('replans', '?')} laws meet the end "
                   "conditions only in part (the goal was out of the step's reach)")
    return out


def report_lines(result) -> list[str]:
    s = result.summary
    lines = [f"{s['mode']} ({s['goal']}): {s['solver'].get('what', '')}"]
    ms = s.get("solve_ms") or {}
    if ms.get("samples"):
        lines.append(f"  solve per sample (CPU time): median {ms['median']:.3f} ms, p99 "
                     f"{ms['p99']:.3f} ms, max {ms['max']:.3f} ms ({ms['samples']} samples)")
    lines += _failure_lines(s)
    for key, name in (("closed_loop", "closed loop"), ("open_loop", "open loop")):
        if key in s:
            words = _goal_words(s[key])
            lines.append(f"  {name}{_stopped(s[key])}: {_achieved(result.task, s[key])}"
                         + (f"; {words}" if words else ""))
    return lines


def _stopped(m: dict) -> str:
    """A run that did not end done, said with its status (control.json's ``status``): the
    measure alone read as if it had (a push's step_underflow showed as an attitude error
    at the time it stopped, a new user's trial)."""
    status = m.get("status")
    return "" if status in (None, "done") else f" (the run stopped early: {status})"

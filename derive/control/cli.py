"""``derive control TASK.toml -o DIR``: the command line of the closed loop.

``add_parser(subparsers)`` adds the subcommand; ``run(args)`` returns the exit status (0
done, 1 when the loop could not be closed: the offline plan failed) and raises
:class:`~derive.scene.SceneError` for bad input (exit status 2 in the CLI: one line
naming the field and the rule, nothing written).
"""
from __future__ import annotations

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
        from .replan import ControlError
        if not isinstance(exc, ControlError):
            raise
        print(f"derive control: {exc}", file=sys.stderr)
        return 1
    written = result.write(args.output, animation=not args.no_animation)
    for line in report_lines(result):
        print(line)
    print(f"  wrote {', '.join(p.name for p in written)} to {args.output}")
    return 0


def _achieved(task, m: dict) -> str:
    from ..planner.goals import goal_of
    return goal_of(task).achieved_text(m)


def report_lines(result) -> list[str]:
    s = result.summary
    lines = [f"{s['mode']} ({s['goal']}): {s['solver'].get('what', '')}"]
    ms = s.get("solve_ms") or {}
    if ms.get("samples"):
        lines.append(f"  solve per sample: median {ms['median']:.3f} ms, p99 {ms['p99']:.3f} "
                     f"ms, max {ms['max']:.3f} ms ({ms['samples']} samples)")
    ctl = s.get("controller") or {}
    if ctl.get("failures"):
        lines.append(f"  {ctl['failures']} of {ctl.get('calls', '?')} calls found no solution "
                     "to their QP (the law in use went on)")
    for key, name in (("closed_loop", "closed loop"), ("open_loop", "open loop")):
        if key in s:
            lines.append(f"  {name}: {_achieved(result.task, s[key])}")
    return lines

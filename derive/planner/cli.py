"""``derive plan TASK.toml -o DIR``: the command line of the planner.

``add_parser(subparsers)`` adds the subcommand; ``run(args)`` returns the exit status
(0 solved, 1 infeasible or failed) and raises :class:`~derive.scene.SceneError`
for bad input (exit status 2 in the CLI: one line naming the field and the rule, nothing
written).
"""
from __future__ import annotations

import sys


def add_parser(subparsers):
    p = subparsers.add_parser(
        "plan", help="plan the point's law with optimal control (CasADi + IPOPT): reorient, "
                     "land or hop")
    p.add_argument("task", help="task TOML: a scene with a [plan] table instead of a point law")
    p.add_argument("-o", "--output", default="plan-out", help="output folder (default: "
                   "plan-out)")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress line per IPOPT iteration")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from .core import plan
    from .task import load_task
    task = load_task(args.task)               # SceneError: bad input, nothing written
    result = plan(task, progress=not args.quiet)
    written = result.write(args.output)
    for line in report_lines(result):
        print(line)
    print(f"  wrote {', '.join(p.name for p in written)} to {args.output}")
    if not result.ok:
        print(f"derive plan: {result.message}", file=sys.stderr)
        return 1
    return 0


def report_lines(result) -> list[str]:
    s = result.summary
    sv = s["solver"]
    lines = [f"{s['goal']}: {s['status']}; IPOPT and defect correction "
             f"{sv['ipopt_and_defect_correction_seconds']:.2f} s ({len(sv['solves'])} solves, "
             f"{sv['iterations']} iterations; {sv['variables']} variables, "
             f"{sv['constraints']} constraints), NLP build {sv['nlp_build_seconds']:.2f} s, "
             f"total {s['total_seconds']:.1f} s"]
    if not result.ok:
        lines.append(f"  {s['message']}")
        return lines
    law = s["law"]
    task = result.task
    lines.append(f"  law: {law['pieces']} pieces over {law['duration']:.6g} s ({law['ends']}), "
                 f"max |OP''| {law['max_acceleration']:.4g} m/s^2 (limit "
                 f"{task.max_acceleration:.4g}), effort {law['effort']:.5g} m^2/s^3")
    for name, meas in s["achieved"].items():
        if meas.get("available") is False:
            lines.append(f"  achieved ({name}): not measured, {meas['reason']}")
            continue
        lines.append(f"  achieved ({name}, re-simulated scene.toml): " + achieved_text(task, meas))
    if "stability" in s:
        st = s["stability"]
        lines.append(f"  multipliers |rho|: {', '.join(f'{m:.4f}' for m in st['moduli'])}")
        lines.append(f"  {st['verdict']}")
    return lines


def achieved_text(task, m: dict) -> str:
    if "error" in m:
        return m["error"]
    if task.goal == "reorient":
        return f"attitude error {m['attitude_error_rad']:.2e} rad at t = {m['t_end']:.6g} s"
    if task.goal == "land":
        text = (f"touchdown at t = {m['touchdown_time']:.9g} s (planned "
                f"{m['touchdown_time'] - m['touchdown_time_error']:.9g})")
        if "attitude_error_rad" in m:
            return text + f", attitude error {m['attitude_error_rad']:.2e} rad"
        return text + f", |d| = {m['d_norm']:.2e}, |omega+ - omega-| = {m['omega_jump']:.2e}"
    return (f"{m['impacts']} impacts, apex error {m['apex_error']:.2e} m, post-impact state "
            f"error {m['max_state_error']:.2e}, period {m['period']:.9g} s")

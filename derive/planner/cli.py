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
                     "land or hop; or the fastest crawl of a body on its face (travel)")
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
    for line in report_lines(result, message=False):     # the message goes to stderr once
        print(line)
    sc = task.scene             # derive control's tables: validated here, read there
    given = [f"[{name}]" for name, table in (("control", sc.control),
                                              ("disturbance", sc.disturbance)) if table]
    if given:
        print(f"  {' and '.join(given)} validated, not used: derive control reads "
              f"{'them' if len(given) > 1 else 'it'} (this plans the model's task, "
              "undisturbed)")
    print(f"  wrote {', '.join(p.name for p in written)} to {args.output}")
    if not result.ok:
        print(f"derive plan: {result.message}", file=sys.stderr)
        return 1
    return 0


def report_lines(result, message: bool = True) -> list[str]:
    """The lines the CLI prints about a plan (from its summary); `message`: with the
    message of a plan that failed (the CLI prints it once, to stderr)."""
    if result.task.goal == "travel":
        return travel_lines(result, message)
    from .goals import goal_of
    s = result.summary
    sv = s.solver
    lines = [f"{s.goal}: {s.status}; IPOPT and defect correction "
             f"{sv.ipopt_and_defect_correction_seconds:.2f} s ({len(sv.solves)} solves, "
             f"{sv.iterations} iterations; {sv.variables} variables, "
             f"{sv.constraints} constraints), NLP build {sv.nlp_build_seconds:.2f} s, "
             f"total {s.total_seconds:.1f} s"]
    if not result.ok:
        if message:
            lines.append(f"  {s.message}")
        if s.blocking and "seconds" in s.blocking:
            b = s.blocking
            lines.append(f"  diagnosis: {b['runs']} IPOPT runs, {b['iterations']} "
                         f"iterations, {b['seconds']:.2f} s")
        return lines
    law = s.law
    task = result.task
    goal = goal_of(task)
    if law.kind == "bodies":
        lines += _bodies_law_lines(law, task)
    else:
        lines.append(f"  law: {law.pieces} pieces over {law.duration:.6g} s ({law.ends}), "
                     f"max |OP''| {law.max_acceleration:.4g} m/s^2 (limit "
                     f"{task.max_acceleration:.4g}), effort {law.effort:.5g} m^2/s^3")
    for name, meas in s.achieved.items():
        if meas.get("available") is False:
            lines.append(f"  achieved ({name}): not measured, {meas['reason']}")
            continue
        lines.append(f"  achieved ({name}, re-simulated scene.toml): "
                     + goal.achieved_text(meas))
    if s.stability is not None:
        st = s.stability
        lines.append(f"  multipliers |rho|: {', '.join(f'{m:.4f}' for m in st['moduli'])}")
        lines.append(f"  {st['verdict']}")
    return lines


def _bodies_law_lines(law, task) -> list[str]:
    """The law of a task of several bodies: one line per decided body."""
    lines = [f"  law: {law.pieces} pieces over {law.duration:.6g} s ({law.ends}) for "
             f"{', '.join(law.decided)}; effort {law.effort:.5g} s (each body's "
             "acceleration over its bound, squared)"]
    for b in law.bodies:
        if "max_rate" in b:
            lines.append(f"    {b['name']}: turns {b['turn']:.6g} rad, max |psi'| "
                         f"{b['max_rate']:.4g} rad/s (limit {task.max_rotor_rate:.4g}), max "
                         f"|psi''| {b['max_acceleration']:.4g} rad/s^2 (limit "
                         f"{task.max_rotor_acceleration:.4g})")
        else:
            lines.append(f"    {b['name']}: max |OP''| {b['max_acceleration']:.4g} m/s^2 "
                         f"(limit {task.max_acceleration:.4g}), at most "
                         f"{b['max_distance_from_region_center']:.4g} m from the region's "
                         "centre")
    return lines


def travel_lines(result, message: bool = True) -> list[str]:
    """The lines of a travel plan (derive/planner/travel.py): the law, its mean speed,
    the closed form's for the same bounds and their ratio."""
    s = result.summary
    cf, b = s["closed_form"], s["bounds"]
    head = f"travel: {s['status']}"
    if "search" in s:
        se = s["search"]
        head += (f"; Nelder-Mead {se['iterations']} iterations, {se['evaluations']} runs of "
                 f"the base model ({se['seconds']:.1f} s)")
    lines = [head + f", total {s['total_seconds']:.1f} s"]
    if not result.ok:
        if message:
            lines.append(f"  {s['message']}")
        return lines
    law, ph = s["law"], s["law"]["phases"]
    others = ", ".join(f"{k} {cf[k]['speed']:.6g} m/s" for k in ("brake", "sawtooth", "rest")
                       if k != cf["class"])
    u = "none" if b["max_velocity"] is None else f"{b['max_velocity']:.4g}"
    lines += [
        f"  law: period {law['period']:.6g} s along {_vec(law['direction'])} through "
        f"{_vec(law['guide_center'])}: hold {ph['hold']:.4g} s, throw {ph['throw']:.4g} s at "
        f"{ph['throw_acceleration']:.5g} m/s^2, coast {ph['coast']:.4g} s, brake "
        f"{ph['brake']:.4g} s at {ph['brake_acceleration']:.5g} m/s^2, return "
        f"{ph['return']:.4g} s at {ph['return_acceleration']:.5g} m/s^2, corners "
        f"{ph['corner']:.3g} s",
        f"  bounds: range {law['range']:.5g} m (limit {b['range']:.5g}), max |OP'| "
        f"{law['max_velocity']:.4g} m/s (limit {u}), max |OP''| "
        f"{law['max_acceleration']:.4g} m/s^2 (limit {b['max_acceleration']:.4g})",
        f"  mean speed {s['mean_speed']:.6g} m/s (forward {s['forward_speed']:.6g}); closed "
        f"form for the same bounds {cf['speed']:.6g} m/s (derive/capsule.py, the "
        f"{cf['class']} class), ratio {s['ratio']:.4f}",
        f"  the other classes: {others}"]
    rt = s["achieved"]["runtime"]
    if rt["mean_velocity"] is not None:
        lines.append(f"  achieved (runtime, re-simulated scene.toml): mean velocity "
                     f"{_vec(rt['mean_velocity'], '.6g')} m/s over {rt['whole_periods']} "
                     "periods")
    else:
        lines.append(f"  achieved (runtime, re-simulated scene.toml): {rt['status']}")
    return lines


def _vec(v, fmt: str = ".3g") -> str:
    return "(" + ", ".join(format(float(x), fmt) for x in v) + ")"

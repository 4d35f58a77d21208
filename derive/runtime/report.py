"""What a run did: in numbers (``summary.json``) and in words (``derive simulate``'s
lines).

:func:`summary` is the document ``summary.json`` holds (the counters, the contact, the
energy balance of :func:`derive.runtime.motion.energy_balance`, the invariants, the
timings); :func:`lines` and :func:`timing_line` are what ``derive simulate`` prints.
Both read the rough model's contact from :func:`contact_friction`, so the times sliding
and sticking printed are the ones written.
"""
from __future__ import annotations

import os
import platform

import numpy as np

from .. import abi, layout
from ..progress import count
from . import base_report, choice
from .events import phases
from .motion import Motion, energy_balance, motion

_SLIDING, _STICKING = abi.MODE["sliding"], abi.MODE["sticking"]


def invariant_drift(result, on_face: bool = False) -> dict:
    """Relative drift of |K| within each flight phase (E1.9; not of a body on its face,
    which never flies), and of A's orthonormality."""
    out = {}
    K = result.momentum["K_norm"]
    worst = 0.0
    for a, b, state in () if on_face else phases(result):
        if state == "flight" and b - a > 1 and K[a] > 0:
            worst = max(worst, float(np.max(np.abs(K[a:b] - K[a])) / K[a]))
    if not on_face:
        out["K_norm_relative_drift_between_events"] = worst
    if result.general is not None:
        A = result.general[:, layout.GENERAL.A].reshape(-1, 3, 3)
        err = np.abs(np.einsum("nij,nkj->nik", A, A) - np.eye(3)).max(axis=(1, 2))
        out["orthonormality_error_max"] = float(err.max())
    return out


def _finite(x: float):
    return float(x) if np.isfinite(x) else None


def summary(result, mo: Motion | None = None, trace: list | None = None) -> dict:
    """What a run did, in numbers; ``energy`` is the balance of
    :func:`derive.runtime.motion.energy_balance` (in joules): ``end - start = at_impacts +
    drive_work_in_flight + drive_work_in_contact (+ change_in_contact_not_split) +
    at_other_events + residual``, and each
    impact's jump is ``restitution_at_impacts`` (the sum of I (v_n- + v_n+)/2, zero for
    e = 1) plus ``drive_work_at_impacts`` (the impulsive work of the point's drive, zero for
    a point at rest in the body); ``drive_work_at_other_events`` is that work in the other
    events' jumps (pushes, the impulse at S that ends a slip).  ``trace``: told the
    residual's share of each flight (:func:`~derive.runtime.motion.energy_balance`)."""
    s = result.scene
    mo = mo if mo is not None else motion(result)
    steps, events = (np.flatnonzero(result.row_kind == abi.ROW_KIND["step"]),
                     np.flatnonzero(result.row_kind != abi.ROW_KIND["step"]))
    base = result.model == "base"
    handed = result.handover
    energy = (base_report.energy(result, mo) if base else base_report.handover_energy(handed)
              if handed is not None else energy_balance(result, mo, trace))
    out = {
        "scene": s.name,
        "status": result.status,
        "model": result.model,
        "why": result.why,
        "method": base_report.METHOD if base else s.method, "rtol": s.rtol, "atol": s.atol,
        "t0": s.t0, "t_end": float(result.t[-1]) if len(result.t) else s.t0,
        "duration": s.duration,
        "counts": {**result.stats, "rows": int(len(result.t)),
                   "trajectory_rows": int(len(steps)), "event_rows": int(len(events)),
                   "events": len(result.events)},
        "trajectory": {"grid": "uniform" if s.output_dt > 0 else "solver steps",
                       "output_dt": s.output_dt if s.output_dt > 0 else None},
        "contact": {"min_height_of_S": _finite(result.min_height),
                    "t_min_height": _finite(result.summary["t_min_height"]),
                    "min_normal_force_in_contact": _finite(result.min_normal),
                    **(contact_friction(result) if result.rough else {}),
                    **(base_report.contact(result) if base else {})},
        "travel": {**travel_of(result, mo), **(base_report.travel(result) if base else {})},
        "energy": energy,
        # (after a hand-over, the flight's: the body on its face before it never flies)
        "invariants": invariant_drift(handed.flight if handed is not None else result, base),
        "timings_s": dict(result.timings),
        "machine": {"processor": platform.processor() or platform.machine(),
                    "cpus": os.cpu_count()},
    }
    if handed is not None:           # the face's contact before the lift-off, and where
        out["contact"]["face"] = base_report.contact(handed.base)
        out["handover"] = handed.summary()
    return out


def travel_of(result, mo: Motion) -> dict:
    """How far C went horizontally: where it ends, the net displacement from its start
    (``distance``, as a study's column) and the length of its horizontal path."""
    end = choice.travel(result.model, result.scene.t0, float(result.t[-1]),
                        result.model_q[-1], choice.start_of_c(result.scene), result.scene)
    xy = np.asarray(mo.r_C)[:, :2]
    return {"X_C_start": float(result.scene.com[0]), "Y_C_start": float(result.scene.com[1]),
            **end, "path_length": float(np.hypot(*np.diff(xy, axis=0).T).sum())}


def contact_friction(result) -> dict:
    """The rough model's contact numbers: mu_f, the restitution law, the largest |R_t|/(mu_f
    R_Z) at the ends of contact steps (at most 1: the cone held), the time sliding and
    sticking (abi.MODES); with couples mu_s, mu_r and the time the spin and the rolling
    are held (abi.COUPLE_BITS)."""
    t, modes = result.t, result.modes
    dt = np.diff(t)
    mid = modes[:-1]
    out = {"friction": result.scene.friction,
           "restitution_model": result.scene.restitution_model,
           "max_friction_ratio": float(result.summary["max_friction_ratio"]),
           "time_sliding": float(dt[mid == _SLIDING].sum()),
           "time_sticking": float(dt[mid == _STICKING].sum())}
    if result.couples_on:          # and the couples: their lengths, the time each is held
        held = result.couples[:-1]
        touching = (mid == _SLIDING) | (mid == _STICKING)
        out.update({"spin_friction": result.scene.spin_friction,
                    "rolling_resistance": result.scene.rolling_resistance,
                    "time_spin_held": float(
                        dt[touching & ((held & abi.COUPLE_BIT["spin"]) != 0)].sum()),
                    "time_rolling_held": float(
                        dt[touching & ((held & abi.COUPLE_BIT["roll"]) != 0)].sum())})
    return out


def lines(scene, result, loop: str | None = None) -> list[str]:
    """``derive simulate``'s report of a run of ``scene``: the status and the model, the
    closed ``loop`` (its description) if any, the steps and events, the rough model's
    friction and couples, the lowest height of S and the smallest reaction."""
    info = result.stats
    out = [f"{scene.name}: {result.status}; model {result.model} ({result.why})"]
    if loop is not None:
        out.append(f"  closed loop ({loop})")
    base = result.model == "base"
    method = base_report.METHOD if base else scene.method
    out.append(f"  {method}, {info['steps']} steps ({info['rejected']} rejected), "
               f"{info['rhs_evaluations']} RHS evaluations" + ("" if base else
               f", {count(info['impacts'], 'impact')}, "
               f"{count(info['contacts'], 'contact phase')}, "
               f"{count(info['lift_offs'], 'lift-off')}"))
    pushes = [ev for ev in result.events if ev["kind"] == "push"]
    if pushes:
        out.append(f"  {count(len(pushes), 'push', 'pushes')} applied: " + ", ".join(
            f"|P| = {ev['value']:.4g} N s at t = {ev['t']:.6g} s" for ev in pushes[:4])
            + (", ..." if len(pushes) > 4 else ""))
    if result.rough:
        out += _friction_lines(scene, result)
    if base:
        out += base_report.lines(result)
    if result.handover is not None:
        out += base_report.handover_lines(result.handover)
    end = choice.travel(result.model, scene.t0, float(result.t[-1]), result.model_q[-1],
                        choice.start_of_c(scene), scene)
    if end["distance"] > 0.0:                  # C moved horizontally: how far
        out.append(f"  C travelled {end['distance']:.4g} m horizontally (from its start to "
                   f"X_C = {end['X_C_end']:.4g}, Y_C = {end['Y_C_end']:.4g} m)")
    if scene.contact_possible and not base:
        mh, mn = result.min_height, result.min_normal
        out.append(f"  lowest height of S {mh:.3g} m" +
                   (f", smallest reaction in contact {mn:.4g} N" if mn < float("inf") else ""))
    return out


def _friction_lines(scene, result) -> list[str]:
    info = result.stats
    if result.couples_on:
        couples = (f"spin friction mu_s = {scene.spin_friction:g} m, rolling resistance "
                   f"mu_r = {scene.rolling_resistance:g} m")
    else:
        couples = "no spin friction or rolling resistance"
    times = contact_friction(result)
    out = [f"  friction mu_f = {scene.friction:g} ({scene.restitution_model}; {couples}): "
           f"{count(info['sticks'], 'stick')}, {count(info['slips'], 'slip')}, "
           f"{count(info['reversals'], 'reversal')} in contact; sticking "
           f"{times['time_sticking']:.4g} s, sliding {times['time_sliding']:.4g} s"]
    if result.couples_on:
        kinds = [ev["kind"] for ev in result.events]
        last = {name: next((ev["t"] for ev in reversed(result.events)
                            if ev["kind"] == f"{name}_stop"), None)
                for name in ("spin", "roll")}
        out.append("  couples: " + "; ".join(
            f"{label} {count(kinds.count(f'{name}_stop'), 'stop')}, "
            f"{count(kinds.count(f'{name}_start'), 'start')} from rest"
            + (f" (last stop at t = {last[name]:.6g} s)" if last[name] is not None else "")
            for name, label in (("spin", "spin"), ("roll", "rolling"))))
    return out


def timing_line(result, outputs_s: float, total_s: float) -> str:
    """Where the time of ``derive simulate`` went: validation, the run (and the library's
    build when this call made it), the outputs (``outputs_s``, with their parts)."""
    t = result.timings
    build = f", library built in {t['library_build_s']:.2f} s (once per machine)" \
        if t.get("load_s", 0.0) > 0.05 else ""
    parts = ", ".join(f"{name[:-2]} {sec:.2f} s" for name, sec in t.get("outputs", {}).items())
    return (f"  validate {1e3 * t['prepare_s']:.2f} ms, run {1e3 * t['run_s']:.2f} ms{build}, "
            f"outputs {outputs_s:.2f} s ({parts}); {total_s:.2f} s in all")

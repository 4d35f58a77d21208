"""``derive stability SCENE.toml``: the multipliers of a scene's periodic motion.

* Free flight (no plane, or shape "none"): the scene's initial state must lie on a
  periodic motion (a stationary rotation of C3.1, C4.1–C4.3, the translational motion
  of C2.5, ...) with the law's period or ``[stability].period``; see
  :mod:`derive.stability.floquet`.
* On the plane: the periodic bouncing of reference [5] with one impact every
  ``[stability].impacts_every`` periods of the point, found by Newton from the table's
  orbit (the scene gives the body, the law, e and the spin); see
  :mod:`derive.stability.bouncing`.
"""
from __future__ import annotations

import numpy as np

from ..scene import Scene, load_scene
from ..scene.stability_keys import refuse_unread
from . import bouncing, floquet


def example(name: str, settings: dict | None = None) -> dict:
    """A scene (as a dict) of a family: ``C4.1``, ``C4.2``, ``C4.3`` (a stationary
    rotation) or ``bounce`` (the reference-[5] carrier on the table's n-orbit); the
    parameters and their checks are in :mod:`derive.stability.families`."""
    from .families import family
    fam = family(name)
    return fam.scene(fam.values(settings))


def analyse(scene, progress: bool = False) -> dict:
    scene: Scene = load_scene(scene)
    refuse_unread(scene)
    st = scene.stability
    if scene.contact_possible:
        result = bouncing.analyse(scene, n=st.impacts_every, long_periods=st.long_periods,
                                  perturbations=st.perturbations,
                                  progress=progress).as_dict()
    else:
        result = floquet.analyse(scene, period=st.period, long_periods=st.long_periods,
                                 perturbations=st.perturbations,
                                 progress=progress).as_dict()
    if st.long_periods and not result.get("long_runs"):
        result["verdict"] += (f"; no perturbed runs (long_periods {st.long_periods}): "
                              "a multiplier outside the unit circle decides")
    result["scene"] = scene.name
    return result


def text(result: dict) -> str:
    """The human-readable report of :func:`analyse`'s result."""
    lines = [f"{result['scene']}: {result['kind']}, period {result['period']:.12g}"]
    if "family" in result:
        lines.append("  parameters: " + ", ".join(
            f"{k}={v:g}" for k, v in result["family"]["parameters"].items()
            if isinstance(v, (int, float))))
    if result["kind"] == "periodic bouncing":
        lines.append(f"  one impact per {result['n']} period(s) of the point, at "
                     f"t = {result['t_impact']:.12g}")
    lines.append("  multipliers (monodromy over one period)       |rho|")
    for (re, im), mod in zip(result["multipliers"], result["moduli"]):
        lines.append(f"    {re:+.12f} {im:+.12f}i   {mod:.12f}")
    if result["kind"] == "periodic bouncing":
        vert = np.array([complex(*p) for p in result["vertical_multipliers"]])
        table = np.array([complex(*p) for p in result["analytic_table_multipliers"]])
        lines.append("  vertical block " + ", ".join(f"{v:.10g}" for v in np.sort_complex(vert))
                     + "; ball on a vibrating table (closed form) "
                     + ", ".join(f"{v:.10g}" for v in np.sort_complex(table)))
    else:
        lines.append(f"  det M = {result['det']:.12g}; Liouville exp(int tr A) = "
                     f"{result['liouville']:.12g}")
        for name, block in result["blocks"].items():
            lines.append(f"  block ({name}): {block['verdict']}")
    lines.append("  checks:")
    for name, c in result["checks"].items():
        lines.append(f"    {name:<22} {c['value']:.2e}  (bound {c['bound']:.0e})  "
                     + ("ok" if c["ok"] else "FAILED"))
    for run in result.get("long_runs", []):
        lines.append(f"  perturbed run, eps = {run['eps']:.0e}, {run['periods']} periods:")
        for label, sfx in (("(omega, n)", ""), ("omega", "_omega")):
            worst = run["max_deviation" + sfx]
            lines.append(f"    {label:<10} max deviation {worst:.3e} = "
                         f"{run['growth_ratio' + sfx]:.3g} x the starting deviation "
                         f"{run['initial' + sfx]:.3e} = {worst / run['eps']:.3g} x eps; "
                         f"envelope ~ t^{run['envelope_exponent' + sfx]:.2f}: "
                         f"{run['growth' + sfx]}")
    lines.append(f"  verdict: {result['verdict']}")
    return "\n".join(lines)


def checks_hold(result: dict) -> bool:
    return all(c["ok"] for c in result["checks"].values())

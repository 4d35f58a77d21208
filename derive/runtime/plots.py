"""``overview.png``: one figure of a run — the motion in space (the body drawn at a few
instants, the traces of C and P, the impacts), and against time the height of S, the
attitude, omega, the energy of the carrier and of the point, the impulses and the drift
of |K| between impacts (E1.9); on a rough plane also the slip speed of S with the contact
modes shaded, and the contact mode with the impacts' tangential impulses.  With several
points every point is drawn (P1, P2, ...), and every rotor as a disc about its axis with a
spoke at its angle; the energy is split per body.

Drawn on a bare :class:`matplotlib.figure.Figure` with the Agg canvas (no pyplot, no
backend selection); legends sit outside the axes so they never hide a curve.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import abi, layout
from ..progress import count

from . import drawing, series
from .events import contact_intervals, impact_rows, phases
from .motion import Motion


# a title at a fixed height: matplotlib's automatic placement measures every tick label
# of the axes (a second for this figure)
_TITLE = {"fontsize": 10, "y": 1.0, "pad": 4}


def scale_into_labels(fig) -> None:
    """Move each y axis' scale and offset ("1e-11", "+1.55e-1" above the axis, where they
    collide with the title) into the axis label: "height of S [m] (ticks x 1e-11)".  The
    ticks are those of the limits already set, so nothing is drawn twice."""
    from matplotlib.ticker import ScalarFormatter
    for ax in fig.axes:
        if getattr(ax, "name", "") != "rectilinear":
            continue
        axis = ax.yaxis
        fmt = axis.get_major_formatter()
        if not isinstance(fmt, ScalarFormatter):
            continue
        fmt.set_locs(axis.get_majorticklocs())
        offset = fmt.get_offset().replace("\u2212", "-")
        if offset:
            axis.offsetText.set_visible(False)
            label = axis.get_label_text()
            scale = offset if offset[0] in "+-" else f"x {offset}"
            axis.set_label_text(f"{label} (ticks {scale})".strip())


def _labels(ax, entries) -> None:
    """A legend without its cost: coloured names stacked in the right margin, outside the
    axes (never over a curve)."""
    n = len(entries)
    for k, (text, colour) in enumerate(entries):
        ax.annotate(text, (1.02, 0.5), xycoords="axes fraction", textcoords="offset points",
                    xytext=(0, 11 * ((n - 1) / 2 - k)), color=colour, fontsize=8,
                    ha="left", va="center")


def _labels_below(ax, entries, per_row: int = 3) -> None:
    """Coloured names in rows under an axes without ticks."""
    for k, (text, colour) in enumerate(entries):
        ax.annotate(text, ((k % per_row) / per_row, 0.0), xycoords="axes fraction",
                    textcoords="offset points", xytext=(0, -4 - 11 * (k // per_row)),
                    color=colour, fontsize=8, ha="left", va="top")


def _impact_lines(ax, impacts):
    if 0 < len(impacts) <= 40:           # more would grey the panel out
        ax.vlines(impacts[:, 0], 0, 1, transform=ax.get_xaxis_transform(), color="0.85",
                  lw=0.6, zorder=0)


# the times written beside the bodies: font size, gap to the body, margins (points)
_TIME_FONT, _TIME_GAP, _TIME_MARGIN = 8, 3.0, 2.0


def _time_text(t: float) -> str:
    return f"t = {t:.2f} s"


def _text_width(text: str) -> float:
    """The width of ``text`` at the times' font size, in points (matplotlib's own text
    layout, with no renderer)."""
    from matplotlib.font_manager import FontProperties
    from matplotlib.textpath import TextToPath
    return TextToPath().get_text_width_height_descent(
        text, FontProperties(size=_TIME_FONT), ismath=False)[0]


def _apart(a, b) -> bool:
    """Two boxes (x0, y0, x1, y1) apart (touching counts as overlapping)."""
    return a[2] < b[0] or b[2] < a[0] or a[3] < b[1] or b[3] < a[1]


def snapshot_rows(bodies: np.ndarray, pictures: np.ndarray, widths, height: float,
                  gap: float, xlim: tuple, most: int = 6) -> list[tuple[int, int]]:
    """Which candidate instants to draw the body at, and on which side to write each
    time: (index, -1 left or +1 right).  Per candidate, in time order, boxes (x0, y0,
    x1, y1) in the panel's data units: ``bodies`` around the body's outline,
    ``pictures`` around all that is drawn of it (the outline and the axes); ``widths``,
    ``height`` and ``gap``: the times' boxes and their gap to the picture, in the same
    units.  The first and the last, then in time order every instant whose body does not
    touch a body chosen and whose picture and time overlap no picture or time chosen (at
    most ``most``); a time is written on the outer side of its body (left of a body left
    of the middle of the travel, right of one right of it) if there is room there, else
    on the other."""
    middle = 0.5 * (bodies[:, 0].min() + bodies[:, 2].max())

    def label(k, side):
        y = 0.5 * (bodies[k, 1] + bodies[k, 3])
        if side < 0:
            x1 = pictures[k, 0] - gap
            return (x1 - widths[k], y - height / 2, x1, y + height / 2)
        x0 = pictures[k, 2] + gap
        return (x0, y - height / 2, x0 + widths[k], y + height / 2)

    chosen: list[tuple[int, int]] = []

    def fits(k):
        if not all(_apart(bodies[k], bodies[j]) and _apart(pictures[k], label(j, s))
                   for j, s in chosen):
            return None
        outer = -1 if 0.5 * (bodies[k, 0] + bodies[k, 2]) <= middle else 1
        for side in (outer, -outer):
            t = label(k, side)
            if xlim[0] <= t[0] and t[2] <= xlim[1] and all(
                    _apart(t, pictures[j]) and _apart(t, label(j, s)) for j, s in chosen):
                return side
        return None

    for k in [0, len(bodies) - 1, *range(1, len(bodies) - 1)]:
        if len(chosen) == most:
            break
        if any(k == j for j, _ in chosen):
            continue
        side = fits(k)
        if side is not None:
            chosen.append((k, side))
    return sorted(chosen)


def _point_text(j: int) -> str:
    """A point's colour in a legend (the first point's orange a shade darker: text)."""
    return "#e6550d" if j == 0 else drawing.point_colour(j)


def _point_entries(mo: Motion, what: str = "") -> list:
    n = len(mo.r_points)
    return [(what + drawing.point_label(j, n), _point_text(j)) for j in range(n)]


def side_panel(ax, result, mo: Motion) -> None:
    """The traces of C, O and the points in the vertical plane of the main travel (X-Z or
    Y-Z), to scale."""
    span = np.ptp(mo.r_C[:, :2], axis=0)
    k = 0 if span[0] >= span[1] else 1
    name = "XY"[k]
    traces = [(P, drawing.point_colour(j), 0.7) for j, P in enumerate(mo.r_points)]
    for pts, colour, lw in (*traces, (mo.r_O, "#3182bd", 0.9), (mo.r_C, "k", 1.2)):
        i = drawing.drawn_rows(mo.t, pts[:, k], pts[:, 2])    # each its own rows: fewer
        ax.plot(pts[i, k], pts[i, 2], color=colour, lw=lw)
    if result.scene.plane:
        ax.axhline(0.0, color="0.4", lw=1.0)
        if len(result.impacts):
            rows = impact_rows(result)
            S = drawing.lowest_points(result.scene, mo.r_O[rows], mo.A[rows])
            S = series.distinct(S[:, [k, 2]])
            ax.plot(S[:, 0], S[:, 1], "x", color="#d62728", ms=6, mew=1.5)
    # to scale unless that would leave most of the panel empty
    box = ax.get_position()
    fw, fh = ax.figure.get_size_inches()
    allz = np.concatenate([*(P[:, 2] for P in mo.r_points), mo.r_C[:, 2],
                           [0.0] if result.scene.plane else []])
    dz = max(float(np.ptp(allz)), 1e-12)
    dx = max(float(np.ptp(np.concatenate([*(P[:, k] for P in mo.r_points), mo.r_O[:, k]]))),
             1e-12)
    panel = (box.width * fw) / (box.height * fh)
    to_scale = 1 / 3 <= (dx / dz) / panel <= 3
    if to_scale:
        ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"{name} [m]", fontsize=9)
    ax.set_ylabel("Z [m]", fontsize=9)
    ax.set_title(f"traces in the vertical plane {name}-Z"
                 + (", to scale" if to_scale else " (not to scale)"), **_TITLE)
    _labels(ax, [("C", "k"), ("O, carrier's centre", "#3182bd"), *_point_entries(mo)]
            + ([("x  impact points S", "#d62728")] if len(result.impacts) else []))


def motion_panel(ax, result, mo: Motion) -> None:
    """The run in space: plane, traces of C and P, the impact points, the body at
    instants where its pictures do not overlap."""
    from matplotlib.collections import LineCollection, PolyCollection
    s = result.scene
    view = drawing.view_for(mo.r_C)
    xlim, ylim, _ = drawing.scene_extent(s, mo)
    _, _, real = drawing.body_surface(s)
    labels = []
    if s.plane:
        poly, grid = drawing.plane_pictures(view, xlim, ylim)
        ax.fill(poly[:, 0], poly[:, 1], color=drawing.PLANE_COLOUR, zorder=0, lw=0)
        ax.add_collection(LineCollection(grid, colors="white", linewidths=0.7, zorder=0.5))
    C, Ps = view(mo.r_C), [view(P) for P in mo.r_points]
    i = drawing.drawn_rows(mo.t, C[:, 0], C[:, 1], *(P[:, k] for P in Ps for k in (0, 1)))
    for j, P in enumerate(Ps):
        ax.plot(P[i, 0], P[i, 1], color=drawing.point_colour(j), lw=0.6, alpha=0.7,
                zorder=1.5)
    ax.plot(C[i, 0], C[i, 1], color="k", lw=1.0, zorder=1.6)
    labels += [("trace of C", "k"), *_point_entries(mo, "trace of ")]
    if len(result.impacts):
        rows = impact_rows(result)
        Sv = series.distinct(view(drawing.lowest_points(s, mo.r_O[rows], mo.A[rows])))
        ax.plot(Sv[:, 0], Sv[:, 1], "x", color="#d62728", ms=6, mew=1.5, zorder=1.7)
        labels.append((f"x  impacts at S ({len(rows)})", "#d62728"))
    # the candidate instants, and the panel's limits from everything that may be drawn
    # (the traces, the plane, the body at every candidate, room for a time on either
    # side) so that the times can be placed by their size in the panel's own units
    cand = np.unique(np.searchsorted(mo.t, np.linspace(mo.t[0], mo.t[-1], 60))
                     .clip(0, len(mo.t) - 1))
    R = drawing.body_reach(s)  # the outline lies within R of the shape's centre
    centres = view(mo.r_O[cand] + mo.A[cand] @ np.asarray(s.center, dtype=float))
    bodies = np.hstack([centres - R, centres + R])
    O = view(mo.r_O[cand])     # the axes reach 1.3 R from O (drawing.body_pictures)
    tips = np.stack([view(mo.r_O[cand] + 1.3 * R * mo.A[cand][:, :, j]) for j in range(3)])
    pictures = np.hstack([np.minimum(bodies[:, :2], np.minimum(O, tips.min(axis=0))),
                          np.maximum(bodies[:, 2:], np.maximum(O, tips.max(axis=0)))])
    texts = [_time_text(mo.t[i]) for i in cand]
    widths_pt = np.array([_text_width(t) for t in texts]) + 2 * _TIME_MARGIN
    pts = np.vstack([C, *Ps, pictures[:, :2], pictures[:, 2:]] + ([poly] if s.plane else []))
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.04 * (hi - lo).max()
    lo, hi = lo - pad, hi + pad
    box = ax.get_position()
    fw, fh = ax.figure.get_size_inches()
    width_pt = box.width * fw * 72.0
    ratio = (box.height * fh) / (box.width * fw)
    room = (widths_pt.max() + _TIME_GAP) / width_pt       # of the panel's width
    # equal scales, the narrower side widened to the panel's proportions
    X = max((hi[0] - lo[0]) / (1.0 - 2.0 * room), (hi[1] - lo[1]) / ratio)
    x0 = 0.5 * (lo[0] + hi[0] - X)
    ymid = 0.5 * (lo[1] + hi[1])
    panel_x, panel_y = (x0, x0 + X), (ymid - 0.5 * X * ratio, ymid + 0.5 * X * ratio)
    unit = X / width_pt                                    # data units per point
    chosen = snapshot_rows(bodies, pictures, widths_pt * unit, _TIME_FONT * 1.25 * unit,
                           _TIME_GAP * unit, panel_x)
    rows = cand[[k for k, _ in chosen]]
    pics = [drawing.body_pictures(view, s, mo.r_O[i], mo.A[i]) for i in rows]
    if s.plane:
        ax.add_collection(PolyCollection([p["shadow"] for p in pics], facecolors="0.35",
                                         alpha=0.15, linewidths=0, zorder=1))
    ax.add_collection(PolyCollection([p["outline"] for p in pics], facecolors="#9ecae1",
                                     edgecolors="#3182bd", alpha=0.45, linewidths=1.0,
                                     linestyles="-" if real else "--", zorder=2))
    back = np.vstack([p["back"] for p in pics])
    front = np.vstack([p["front"] for p in pics])
    ax.plot(back[:, 0], back[:, 1], color="#3182bd", lw=0.4, alpha=0.35, zorder=2.5)
    ax.plot(front[:, 0], front[:, 1], color="#3182bd", lw=0.6, alpha=0.8, zorder=3.5)
    ax.add_collection(LineCollection([p["axes"][k] for p in pics for k in range(3)],
                                     colors=list(drawing.AXIS_COLOURS) * len(pics),
                                     linewidths=1.5, zorder=4))
    _draw_rotors(ax, view, s, mo, rows, zorder=4.5)
    for j, P in enumerate(mo.r_points):
        Pv = view(P[rows])
        ax.plot(Pv[:, 0], Pv[:, 1], "o", color=drawing.point_colour(j), mec="k", mew=0.6,
                ms=5, zorder=5)
    labels += [("body x axis", drawing.AXIS_COLOURS[0]), ("body y axis",
               drawing.AXIS_COLOURS[1]), ("body z axis", drawing.AXIS_COLOURS[2])]
    labels += [("o  the point P", "#e6550d")] if len(mo.r_points) == 1 and not s.rotors \
        else _point_entries(mo, "o  ")
    if s.rotors:
        labels.append((f"rotors ({len(s.rotors)}): disc, spoke at psi", drawing.ROTOR_COLOUR))
    for k, side in chosen:            # written where snapshot_rows made room for it
        ax.annotate(texts[k], (pictures[k, 0 if side < 0 else 2], centres[k, 1]),
                    textcoords="offset points", xytext=(side * (_TIME_GAP + _TIME_MARGIN), 0),
                    ha="right" if side < 0 else "left", va="center", fontsize=_TIME_FONT,
                    annotation_clip=False)
    ax.set_xlim(*panel_x)
    ax.set_ylim(*panel_y)
    ax.set_aspect("equal")
    ax.set_axis_off()
    if 2.0 * R < _SMALL_BODY * X:        # a long path: the body also drawn at its own scale
        _body_inset(ax, view, s, mo, int(rows[-1]), R, real)
    note = "" if real else "\n(no surface: the body drawn as its equivalent ellipsoid of inertia)"
    ax.set_title(f"the motion, from azimuth {view.az:.0f}°, elevation {view.el:.0f}°"
                 f"{note}", **_TITLE)
    _labels_below(ax, labels)


_SMALL_BODY = 0.12      # of the panel's width: a body drawn smaller also gets an inset


def _draw_rotors(ax, view, s, mo: Motion, rows, zorder: float) -> None:
    """Every rotor at the rows: its rim and its spoke (drawing.rotor_pictures)."""
    from matplotlib.collections import LineCollection
    if not s.rotors:
        return
    lines = [line for i in np.atleast_1d(rows)
             for pic in drawing.rotor_pictures(view, s, mo.r_O[i], mo.A[i],
                                               mo.bodies.psi[:, i, 0])
             for line in (pic["rim"], pic["spoke"])]
    ax.add_collection(LineCollection(lines, colors=drawing.ROTOR_COLOUR, linewidths=1.0,
                                     zorder=zorder))


def _body_inset(ax, view, s, mo, row: int, R: float, real: bool) -> None:
    """The body at ``row`` enlarged in a corner of the motion panel, for a run whose path
    dwarfs it (a robot rolling metres): the same view, axes and point P."""
    from matplotlib.collections import LineCollection, PolyCollection
    inset = ax.inset_axes([0.66, 0.0, 0.34, 0.34])
    pic = drawing.body_pictures(view, s, mo.r_O[row], mo.A[row])
    inset.add_collection(PolyCollection([pic["outline"]], facecolors="#9ecae1",
                                        edgecolors="#3182bd", alpha=0.45, linewidths=1.0,
                                        linestyles="-" if real else "--"))
    inset.plot(pic["back"][:, 0], pic["back"][:, 1], color="#3182bd", lw=0.4, alpha=0.35)
    inset.plot(pic["front"][:, 0], pic["front"][:, 1], color="#3182bd", lw=0.6, alpha=0.8)
    inset.add_collection(LineCollection(list(pic["axes"]), colors=list(drawing.AXIS_COLOURS),
                                        linewidths=1.5))
    _draw_rotors(inset, view, s, mo, row, zorder=2)
    for j, P in enumerate(mo.r_points):
        Pv = view(P[row:row + 1])
        inset.plot(Pv[:, 0], Pv[:, 1], "o", color=drawing.point_colour(j), mec="k", mew=0.6,
                   ms=5)
    c = view(mo.r_O[row:row + 1] + mo.A[row] @ np.asarray(s.center, dtype=float))[0]
    inset.set_xlim(c[0] - 1.4 * R, c[0] + 1.4 * R)
    inset.set_ylim(c[1] - 1.4 * R, c[1] + 1.4 * R)
    inset.set_aspect("equal")
    inset.set_xticks([])
    inset.set_yticks([])
    for side in inset.spines.values():
        side.set_color("0.7")
    inset.set_title(f"{_time_text(mo.t[row])}, enlarged", fontsize=_TIME_FONT, pad=2)


MODE_COLOURS = {abi.MODE["sliding"]: "#fdd0a2", abi.MODE["sticking"]: "#c7e9c0"}


def _mode_spans(ax, t, modes) -> None:
    """The sliding and sticking stretches shaded."""
    edges = np.flatnonzero(np.diff(modes)) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges, [len(t) - 1]])
    for a, b in zip(starts, ends):
        colour = MODE_COLOURS.get(int(modes[a]))
        if colour is not None and t[b] > t[a]:
            ax.axvspan(t[a], t[b], color=colour, lw=0, zorder=0)


def friction_panels(ax_slip, ax_mode, result) -> None:
    """The rough model: the slip speed of S (sliding and sticking shaded) and the contact
    mode with the impacts' tangential impulses (and, with couples, where the spin and the
    rolling are held)."""
    t, modes = result.t, result.modes
    speed = np.hypot(*result.slip.T)
    i = drawing.drawn_rows(t, speed)
    ax_slip.plot(t[i], speed[i], lw=1, color="C3")
    _mode_spans(ax_slip, t, modes)
    ax_slip.set_ylabel("|v_t| [m/s]", fontsize=9)
    ax_slip.set_title(f"slip speed of S (mu_f = {result.scene.friction:g})", **_TITLE)
    _labels(ax_slip, [("slip speed", "C3"), ("sliding", "#e6550d"), ("sticking", "#41ab5d")])
    ax_slip.set_xlim(t[0], t[-1])
    ax_mode.step(t, modes, where="post", lw=1, color="k")
    names = ["flight", "sliding", "sticking"]
    ticks = [abi.MODE[name] for name in names]
    if result.couples_on:          # the couples' channels held: a bar each while held
        touching = (modes == abi.MODE["sliding"]) | (modes == abi.MODE["sticking"])
        for channel, level, name, colour in (("spin", 1.25, "spin held", "C4"),
                                             ("roll", 0.75, "rolling held", "C9")):
            held = ((result.couples & abi.COUPLE_BIT[channel]) != 0) & touching
            ax_mode.step(t, np.where(held, level, np.nan), where="post", lw=3, color=colour)
            ticks.append(level)
            names.append(name)
    ax_mode.set_yticks(ticks)
    ax_mode.set_yticklabels(names, fontsize=8)
    ax_mode.set_ylim(-0.3, 3.3)
    imp = result.impacts_friction
    if len(imp):
        tw = ax_mode.twinx()
        pt = np.hypot(imp[:, 0], imp[:, 1])
        tw.vlines(result.impacts[:, 0], 0.0, pt, color="C0", lw=1.2)
        tw.plot(result.impacts[:, 0], pt, "o", color="C0", ms=3)
        tw.set_ylim(0.0, 1.1 * max(pt.max(), 1e-300))
        tw.tick_params(labelsize=8)
        tw.set_ylabel("|P_t| [N s]", fontsize=9, color="C0")
    ax_mode.set_title("contact mode" + ("; couples held" if result.couples_on else "")
                      + "; impacts' tangential impulses |P_t|", **_TITLE)
    ax_mode.set_xlim(t[0], t[-1])


def _columns(ax, dpi: int) -> int:
    """The pixel columns of an axes at ``dpi``: a long series is drawn per column."""
    return max(1, int(np.ceil(ax.get_position().width * ax.figure.get_figwidth() * dpi)))


def overview(result, mo: Motion, path: Path, dpi: int = 80, steps=None,
             energy_trace: list | None = None) -> Path:
    """``result`` and ``mo``: the rows to draw; ``steps``: the run at its own rows (the
    ends of steps), for the drift of |K|, which the dense output's interpolation error
    would hide, and of E (default: ``result``); ``energy_trace``: the balance's share of
    each flight (:func:`~derive.runtime.motion.energy_balance` of ``steps``: the summary's,
    when it was computed already; else computed here)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    s = result.scene
    t = result.t
    imp = result.impacts
    has_motion = mo.r_O is not None
    rough = result.slip is not None
    n_rows = 4 if rough else 3
    rows = n_rows + (1 if has_motion else 0)
    height = 2.7 * n_rows + (4.6 if has_motion else 0.0) + 1.0
    fig = Figure(figsize=(12.0, height))
    FigureCanvasAgg(fig)
    # fixed margins (a layout engine measures every label: seconds on a busy machine);
    # the gap between the columns holds the left column's legends
    gs = fig.add_gridspec(rows, 2, height_ratios=([4.6 / 2.7] if has_motion else [])
                          + [1] * n_rows, left=0.06, right=0.87, top=1 - 0.8 / height,
                          bottom=0.45 / height, wspace=0.45, hspace=0.42)
    n_contact = len(contact_intervals(result))
    phases_text = f", {count(n_contact, 'contact phase')}" if n_contact else ""
    method = "dop853" if result.model == "base" else s.method   # (base_report.METHOD)
    fig.suptitle(f"{s.name}: {result.model} model, {method}, {result.status}; "
                 f"{count(len(imp), 'impact')}{phases_text}", fontsize=12, y=1 - 0.15 / height,
                 va="top")
    if has_motion:
        motion_panel(fig.add_subplot(gs[0, 0]), result, mo)
        side_panel(fig.add_subplot(gs[0, 1]), result, mo)
    r0 = 1 if has_motion else 0
    # the energy's cell holds two axes: its parts, and under them the total's drift in
    # flight (none on the face, where nothing flies, nor without the energy)
    drifts = mo.T is not None and result.model != "base"
    energy_cell = gs[r0 + 1, 1].subgridspec(2, 1, height_ratios=[2.3, 1], hspace=0.1) \
        if drifts else None
    panels = [fig.add_subplot(energy_cell[0] if i == 3 and drifts
                              else gs[r0 + i // 2, i % 2]) for i in range(2 * n_rows)]
    if drifts:
        ax_drift = fig.add_subplot(energy_cell[1], sharex=panels[3])
        ax_drift.tick_params(labelsize=8)
        ax_drift.grid(True, lw=0.4, color="0.9")
    for ax in panels:
        ax.tick_params(labelsize=8)
        ax.grid(True, lw=0.4, color="0.9")
    for ax in panels[-2:]:
        ax.set_xlabel("t [s]", fontsize=9)
    if rough:
        friction_panels(panels[6], panels[7], result)

    ax = panels[0]
    if mo.h is not None:
        series.draw(ax, t, mo.h, "C0", _columns(ax, dpi))
        if s.plane:
            ax.axhline(0.0, color="k", lw=0.8)
        _impact_lines(ax, imp)
        spans = contact_intervals(result)
        for c0, c1 in spans:
            ax.axvspan(c0, min(c1, t[-1]), color="#c7e9c0", lw=0, zorder=0)
        if spans:
            _labels(ax, [("in contact", "#41ab5d")])
        ax.set_ylabel("height of S [m]", fontsize=9)
        mh = result.summary.get("t_min_height", np.nan)
        if not s.plane:
            ax.set_title("height of the lowest point S (no plane: nothing to touch)",
                         **_TITLE)
        else:
            ax.set_title(f"height of the lowest point S (min {result.min_height:.3g} m"
                         + (f" at t = {mh:.3g} s)" if np.isfinite(mh) else ")"), **_TITLE)
    elif mo.r_O is not None:
        curves = [(P, drawing.point_colour(j)) for j, P in enumerate(mo.r_points)]
        for pts, colour in (*curves, (mo.r_O, "#3182bd"), (mo.r_C, "k")):
            series.draw(ax, t, pts[:, 2], colour, _columns(ax, dpi))
        ax.set_ylabel("[m]", fontsize=9)
        ax.set_title("heights of C, O and the points (no surface: no lowest point)", **_TITLE)
        _labels(ax, [("Z_C", "k"), ("Z_O", "#3182bd"), *_point_entries(mo, "Z_")])
    else:
        ax.text(0.5, 0.5, "no surface: no lowest point", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_title("height of S", **_TITLE)

    ax = panels[1]
    n = mo.A[:, 2, :] if mo.A is not None else \
        (result.model_q[:, layout.VERTICAL.n] if result.model == "vertical" else None)
    if n is not None:
        elev = np.degrees(np.arcsin(np.clip(n, -1.0, 1.0)))
        for k in range(3):
            series.draw(ax, t, elev[:, k], drawing.AXIS_COLOURS[k], _columns(ax, dpi))
        ax.set_ylim(-95, 95)
        ax.set_yticks([-90, -45, 0, 45, 90])
        _impact_lines(ax, imp)
        ax.set_ylabel("above the horizontal [deg]", fontsize=9)
        ax.set_title("attitude: elevation of the body axes, asin(a_3j)", **_TITLE)
        _labels(ax, [(f"body {c} axis", col) for c, col in zip("xyz", drawing.AXIS_COLOURS)])
    else:
        ax.text(0.5, 0.5, "attitude not computed by this model", ha="center",
                va="center", transform=ax.transAxes)

    ax = panels[2]
    for k in range(3):
        series.draw(ax, t, mo.omega[:, k], drawing.AXIS_COLOURS[k], _columns(ax, dpi))
    _impact_lines(ax, imp)
    ax.set_ylabel("[rad/s]", fontsize=9)
    ax.set_title("angular velocity in body axes", **_TITLE)
    _labels(ax, [(f"omega_{c}", col) for c, col in zip("xyz", drawing.AXIS_COLOURS)])

    ax = panels[3]
    if mo.T is not None:
        split = mo.T_carrier is not None
        n_p = len(mo.T_points) if split else 0
        curves = ([(mo.T_carrier, 1, "#3182bd"),
                   *((T, 1, drawing.point_colour(j)) for j, T in enumerate(mo.T_points)),
                   *((T, 1, drawing.ROTOR_COLOUR) for T in mo.T_rotors)]
                  if split else [(mo.T, 1, "#3182bd")]) \
            + [(mo.U, 1, "0.55"), (mo.E, 1.4, "k")]
        entries = ([("carrier, kinetic", "#3182bd")]
                   + ([("point, kinetic", "#e6550d")] if n_p == 1 and not len(mo.T_rotors)
                      else _point_entries(mo, "kinetic, "))
                   + ([(f"rotors' spin ({len(mo.T_rotors)})", drawing.ROTOR_COLOUR)]
                      if len(mo.T_rotors) else [])) if split else [("kinetic", "#3182bd")]
        for y, lw, colour in curves:
            series.draw(ax, t, y, colour, _columns(ax, dpi), lw=lw)
        # margins: the total (often the highest) off the frame's edge
        lo = min(float(np.nanmin(y)) for y, _, _ in curves)
        hi = max(float(np.nanmax(y)) for y, _, _ in curves)
        pad = 0.06 * (hi - lo) or 0.06 * max(abs(hi), 1.0)
        ax.set_ylim(lo - pad, hi + pad)
        entries += [("potential", "0.45"), ("total", "k")]
        _impact_lines(ax, imp)
        ax.set_ylabel("[J]", fontsize=9)
        ax.set_title("energy (potential: (m+M) g Z_C)", **_TITLE)
        _labels(ax, entries)
        if drifts:
            ax.tick_params(labelbottom=False)
            _energy_drift(ax_drift, result, mo, steps if steps is not None else result,
                          energy_trace, dpi)
    else:
        ax.text(0.5, 0.5, "energy needs the motion of C", ha="center", va="center",
                transform=ax.transAxes)

    ax = panels[4]
    cols = _columns(ax, dpi)
    if series.dense(len(imp), cols):     # per pixel column: a stem to the highest impulse
        edges, _, hi = series.envelope(imp[:, 0], imp[:, 1], cols,
                                        span=(t[0], max(t[-1], t[0] + 1e-9)))
        at = np.isfinite(hi)
        mid = 0.5 * (edges[:-1] + edges[1:])[at]
        ax.vlines(mid, 0.0, hi[at], color="C0", lw=0.8)
        ax.plot(mid, hi[at], "o", color="C0", ms=2, ls="none")
        ax.set_ylim(0.0, 1.1 * max(imp[:, 1].max(), 1e-300))
    elif len(imp):
        ax.vlines(imp[:, 0], 0.0, imp[:, 1], color="C0", lw=1.2)
        ax.plot(imp[:, 0], imp[:, 1], "o", color="C0", ms=4)
        ax.set_ylim(0.0, 1.1 * max(imp[:, 1].max(), 1e-300))
    else:
        ax.text(0.5, 0.5, "no impacts", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlim(t[0], max(t[-1], t[0] + 1e-9))   # (a run stopped at its start: one instant)
    ax.set_ylabel("impulse I [N s]", fontsize=9)
    ax.set_title(f"impulses ({count(len(imp), 'impact')}"
                 + ("; per pixel column the highest" if series.dense(len(imp), cols)
                    else "") + ")", **_TITLE)

    ax = panels[5]
    steps = steps if steps is not None else result
    K, tK = steps.momentum["K_norm"], steps.t
    worst, drawn, in_flight = 0.0, False, 0.0
    # a relative difference of two doubles is resolved to half an ulp of 1: a drift of
    # exactly 0 is drawn there (on a log axis 0 has no place, and a floor far below it
    # drew every exact row as a spike down, breaking the curve into segments)
    floor = float(np.finfo(float).eps) / 2
    # the flights' drifts as one series, a NaN between two (one call to draw: a call per
    # flight took 20 s for 21,834 impacts)
    pieces_t, pieces_y = [], []
    for a, b, state in phases(steps):
        if state == "flight":
            in_flight += float(tK[b - 1] - tK[a])
        if state == "flight" and b - a > 2 and K[a] > 0:
            drift = np.abs(K[a + 1:b] - K[a]) / K[a]
            worst = max(worst, float(drift.max()))
            pieces_t += [tK[a + 1:b], tK[b - 1:b]]
            pieces_y += [np.maximum(drift, floor), [np.nan]]
            drawn = True
    if drawn:
        tt, yy = np.concatenate(pieces_t), np.concatenate(pieces_y)
        if len(tt) < 60 + len(pieces_t) // 2:                 # few steps: each shown
            ax.plot(tt, yy, lw=1, color="C0", marker=".", ms=3)
        else:
            series.draw(ax, tt, yy, "C0", _columns(ax, dpi))
        ax.axhline(floor, color="0.6", lw=0.8, ls=":")
        ax.text(0.99, floor, "round-off (0 drawn here)", transform=ax.get_yaxis_transform(),
                ha="right", va="bottom", fontsize=7, color="0.45")
        from matplotlib.ticker import FuncFormatter, LogLocator, NullLocator
        # a log axis' minor ticks and mathtext labels cost 0.4 s: plain labels, major only
        ax.set_yscale("log")
        ax.set_ylim(floor / 1.5, max(worst, floor) * 3.0)
        ax.yaxis.set_minor_locator(NullLocator())
        # ticks at 1, 2 and 5 of each decade: a drift at round-off spans less than one
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0), numticks=6))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.0e}"))
    span = float(t[-1] - t[0])
    if in_flight < 0.01 * span:     # nothing to see: say why rather than draw empty axes
        note = (f"E1.9 holds in flight; this run flies {in_flight:.2g} s of {span:.3g} s"
                if in_flight > 0 else "E1.9 holds in flight; this run never flies")
        ax.text(0.5, 0.5, note, ha="center", va="center", transform=ax.transAxes, fontsize=9)
        ax.set_yticks([])
        ax.set_yticks([], minor=True)
    elif not drawn:
        ax.text(0.5, 0.5, "K = 0 in every flight", ha="center", va="center",
                transform=ax.transAxes)
    ax.set_ylabel("relative drift", fontsize=9)
    ax.set_title(f"| |K| - |K| at phase start | / |K| in flight (E1.9), max {worst:.1e}"
                 + (" (at the steps' ends)" if steps is not result else ""), **_TITLE)
    ax.set_xlim(t[0], max(t[-1], t[0] + 1e-9))   # (a run stopped at its start: one instant)

    for ax in panels[:4]:
        ax.set_xlim(t[0], max(t[-1], t[0] + 1e-9))   # (a run stopped at its start: one instant)
    if result.model == "base":          # a body on its face: no flight, no impacts
        _base_panels(panels[0], panels[4], panels[5], result, mo)
    scale_into_labels(fig)
    fig.savefig(path, dpi=dpi)
    return path


def _energy_drift(ax, result, mo: Motion, steps, trace, dpi: int) -> None:
    """Under the energy's parts, the total's drift in flight (series.energy_drift): the
    balance's residual as it grows, from the balance of the run's own rows."""
    from .motion import energy_balance, motion
    ax.set_xlim(result.t[0], max(result.t[-1], result.t[0] + 1e-9))
    if not trace:         # (not the summary's: drawn alone, or a hand-over's, whose
        trace = []        # balance is its flight's)
        handed = getattr(steps, "handover", None)
        run = handed.flight if handed is not None else steps
        energy_balance(run, mo if run is result else motion(run), trace)
    drift = series.energy_drift(trace, float(mo.E[0]), float(result.t[0]))
    if drift is None:
        ax.text(0.5, 0.5, "no flight: no drift of E to draw", ha="center", va="center",
                transform=ax.transAxes, fontsize=8)
        ax.set_yticks([])
        return
    td, d = drift
    if series.dense(len(td), _columns(ax, dpi)):
        series.draw(ax, td, d, "k", _columns(ax, dpi))
    else:
        ax.plot(td, d, lw=1, color="k", marker="." if len(td) < 60 else None, ms=3)
    ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
    # three ticks written out (an axis' "1e-7" offset made the short axes' label too long)
    worst = float(f"{float(np.max(np.abs(d))):.1e}") or 1e-16
    ax.set_ylim(-1.3 * worst, 1.3 * worst)
    ax.set_yticks([-worst, 0.0, worst], [f"{-worst:.1e}", "0", f"{worst:.1e}"])
    ax.set_ylabel("drift of E", fontsize=8)
    _labels(ax, [("in flight, at each", "k"), ("flight's end,", "k"), ("relative to E(0):", "k"),
                 (f"end {d[-1]:.1e}", "k")])


def _base_panels(ax_x, ax_v, ax_psi, result, mo) -> None:
    """The overview's base panels: C's and O's horizontal position, O's speed and the yaw
    rate, the yaw; sticking and sliding shaded."""
    from .base_report import modes
    t = result.t
    m = modes(result)
    for ax in (ax_x, ax_v, ax_psi):
        ax.clear()
        ax.tick_params(labelsize=8)
        ax.grid(True, lw=0.4, color="0.9")
        _mode_spans(ax, t, m)
        ax.set_xlim(t[0], max(t[-1], t[0] + 1e-9))   # (a run stopped at its start: one instant)
    for k, (name, style) in enumerate((("X", "-"), ("Y", "--"))):
        ax_x.plot(t, mo.r_C[:, k], style, lw=1, color="k")
        ax_x.plot(t, mo.r_O[:, k], style, lw=1, color="#3182bd")
    ax_x.set_ylabel("[m]", fontsize=9)
    ax_x.set_title("C and O horizontally (X solid, Y dashed)", **_TITLE)
    _labels(ax_x, [("C", "k"), ("O", "#3182bd"), ("sliding", "#e6550d"),
                   ("sticking", "#41ab5d")])
    q = result.model_q
    ax_v.plot(t, np.hypot(q[:, 3], q[:, 4]), lw=1, color="#3182bd")
    ax_v.set_ylabel("|V_O| [m/s]", fontsize=9)
    tw = ax_v.twinx()
    tw.plot(t, q[:, 5], lw=1, color="C3")
    tw.tick_params(labelsize=8)
    tw.set_ylabel("psi' [rad/s]", fontsize=9, color="C3")
    ax_v.set_title("O's speed and the yaw rate", **_TITLE)
    ax_psi.plot(t, np.degrees(q[:, 2]), lw=1, color="C3")
    ax_psi.set_ylabel("psi [deg]", fontsize=9)
    ax_psi.set_title("yaw of the face frame", **_TITLE)
    ax_psi.set_xlabel("t [s]", fontsize=9)
    ax_v.set_xlabel("t [s]", fontsize=9)

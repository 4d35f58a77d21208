"""``motion.gif``: the run as an animation — the plane with its grid, the body as its
shape (outline, principal sections, shadow) with its axes, the point P (every point, and
every rotor as a disc with a spoke at its angle), the trace of C so far and the impacts
marked where S hit the plane.

Made to be quick (about a second for the built-in scene): a small Agg figure; the plane
and the whole trace of C (faint) drawn once and kept as the background; per frame only the
moving artists are redrawn over it (blitting); the pixels go straight to Pillow frames
with one shared palette, and Pillow writes the GIF.  At most ``MAX_FRAMES`` frames at
``FPS`` frames per second: runs longer than ``MAX_FRAMES / FPS`` seconds play faster than
real time, and the caption says how much.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import layout

from . import bodies, drawing
from .events import impact_rows
from .motion import Motion

FPS = 20
MAX_FRAMES = 121
SIZE = (5.6, 4.2)       # inches, at DPI
DPI = 90


def frame_times(t0: float, t1: float) -> tuple[np.ndarray, float]:
    """Frame times (1/FPS apart in real time, the last at t1) and the speed-up."""
    span = t1 - t0
    n = int(min(MAX_FRAMES, np.floor(span * FPS + 1e-9) + 1))
    if n >= 2 and n < MAX_FRAMES:
        times = t0 + np.arange(n) / FPS
        return (np.append(times, t1) if t1 - times[-1] > 1e-9 else times), 1.0
    n = max(n, 2)
    return np.linspace(t0, t1, n), span / ((n - 1) / FPS)


def _orthonormal(A: np.ndarray) -> np.ndarray:
    u, _, vt = np.linalg.svd(A)
    return u @ vt


def interpolate(mo: Motion, scene, times: np.ndarray) -> dict:
    """r_C, A (re-orthonormalised) at ``times`` by linear interpolation between rows (the
    rows around an event share its time: positions and attitude are continuous there),
    then O and the points (``r_points``; ``r_P`` the first) and the rotors' angles
    (``psi``) from the law at the frame times exactly."""
    t = mo.t
    r_C = np.column_stack([np.interp(times, t, mo.r_C[:, k]) for k in range(3)])
    A = np.stack([np.interp(times, t, mo.A[:, i, j]) for i in range(3) for j in range(3)],
                 axis=1).reshape(-1, 3, 3)
    A = _orthonormal(A)
    if not scene.one_point:
        b = bodies.along(scene, times)
        r_O, r_points = bodies.positions(scene, b, r_C, A)
        return {"r_C": r_C, "A": A, "r_O": r_O, "r_points": r_points, "psi": b.psi[:, :, 0]}
    r = scene.law.jets(times)[list(layout.JET_R)].T
    Ar = np.einsum("nij,nj->ni", A, r)
    r_O = r_C - scene.nu * Ar
    return {"r_C": r_C, "A": A, "r_O": r_O, "r_P": r_O + Ar, "r_points": (r_O + Ar)[None],
            "psi": np.zeros((0, len(times)))}


def write_gif(result, mo: Motion, path: Path) -> Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon
    from PIL import Image

    s = result.scene
    times, speed = frame_times(float(mo.t[0]), float(mo.t[-1]))
    st = interpolate(mo, s, times)
    view = drawing.view_for(mo.r_C)
    xlim, ylim, _ = drawing.scene_extent(s, mo)
    _, _, real = drawing.body_surface(s)

    fig = Figure(figsize=SIZE, dpi=DPI)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0.0, 0.0, 1.0, 0.9))
    ax.set_axis_off()
    fig.text(0.5, 0.965, f"{s.name}: {result.model} model"
             + (f" (played {speed:.3g}x faster)" if speed > 1.001 else ""),
             ha="center", va="center", fontsize=10)

    # static background: plane, grid, the whole trace of C (faint)
    pics0 = [drawing.body_pictures(view, s, st["r_O"][k], st["A"][k])
             for k in range(0, len(times), max(1, len(times) // 12))]
    pts = [view(mo.r_C), *(view(P) for P in mo.r_points), *(p["outline"] for p in pics0),
           *(p["axes"].reshape(-1, 2) for p in pics0)]
    if s.plane:
        poly, grid = drawing.plane_pictures(view, xlim, ylim)
        ax.fill(poly[:, 0], poly[:, 1], color=drawing.PLANE_COLOUR, lw=0)
        ax.add_collection(LineCollection(grid, colors="white", linewidths=0.8))
        pts.append(poly)
    C = view(mo.r_C)
    drawn = drawing.drawn_rows(mo.t, C[:, 0], C[:, 1])
    C, t_drawn = C[drawn], mo.t[drawn]
    ax.plot(C[:, 0], C[:, 1], color="0.75", lw=0.6)
    pts = np.vstack(pts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.04 * (hi - lo).max()
    lo, hi = lo - pad, hi + pad
    ratio = (0.9 * SIZE[1]) / SIZE[0]
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    if half[1] / half[0] < ratio:
        half[1] = half[0] * ratio
    else:
        half[0] = half[1] / ratio
    ax.set_xlim(mid[0] - half[0], mid[0] + half[0])
    ax.set_ylim(mid[1] - half[1], mid[1] + half[1])
    ax.set_aspect("equal")

    # impacts: where S was at each impact
    rows = impact_rows(result)
    S_imp = view(drawing.lowest_points(s, mo.r_O[rows], mo.A[rows])) if len(rows) \
        else np.zeros((0, 2))
    t_imp = mo.t[rows] if len(rows) else np.zeros(0)

    # moving artists
    anim = []

    def add(artist):
        artist.set_animated(True)
        anim.append(artist)
        return artist

    shadow = add(ax.add_patch(Polygon(np.zeros((3, 2)), closed=True, fc="0.3", alpha=0.18,
                                      lw=0)))
    trace, = ax.plot([], [], color="k", lw=1.0)
    add(trace)
    marks, = ax.plot([], [], "x", color="#d62728", ms=6, mew=1.6)
    add(marks)
    back, = ax.plot([], [], color="#3182bd", lw=0.5, alpha=0.35)
    add(back)
    body = add(ax.add_patch(Polygon(np.zeros((3, 2)), closed=True, fc="#9ecae1", alpha=0.45,
                                    ec="#3182bd", lw=1.2, ls="-" if real else "--")))
    front, = ax.plot([], [], color="#3182bd", lw=0.7, alpha=0.85)
    add(front)
    axes_lines = add(ax.add_collection(LineCollection([], colors=drawing.AXIS_COLOURS,
                                                      linewidths=1.8)))
    points = [add(ax.plot([], [], "o", color=drawing.point_colour(j), mec="k", mew=0.7,
                          ms=6)[0]) for j in range(len(st["r_points"]))]
    rotors = add(ax.add_collection(LineCollection([], colors=drawing.ROTOR_COLOUR,
                                                  linewidths=1.1)))
    h = mo.h
    # text through Pillow: matplotlib's text costs milliseconds a frame
    from PIL import ImageDraw, ImageFont
    font = ImageFont.load_default(size=12)
    height_px = int(round(SIZE[1] * DPI))

    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    frames = []
    for k, tk in enumerate(times):
        pic = drawing.body_pictures(view, s, st["r_O"][k], st["A"][k])
        shadow.set_xy(pic["shadow"])
        shadow.set_visible(bool(s.plane))
        upto = np.searchsorted(t_drawn, tk, side="right")
        trace.set_data(C[:upto, 0], C[:upto, 1])
        seen = t_imp <= tk
        marks.set_data(S_imp[seen, 0], S_imp[seen, 1])
        back.set_data(pic["back"][:, 0], pic["back"][:, 1])
        body.set_xy(pic["outline"])
        front.set_data(pic["front"][:, 0], pic["front"][:, 1])
        axes_lines.set_segments(list(pic["axes"]))
        for j, point in enumerate(points):
            p = view(st["r_points"][j, k])
            point.set_data([p[0]], [p[1]])
        rotors.set_segments([line for pic in drawing.rotor_pictures(
            view, s, st["r_O"][k], st["A"][k], st["psi"][:, k])
            for line in (pic["rim"], pic["spoke"])])
        hk = np.interp(tk, mo.t, h) if h is not None else None
        canvas.restore_region(background)
        for a in anim:
            ax.draw_artist(a)
        buf = canvas.buffer_rgba()
        image = Image.frombuffer("RGBA", (buf.shape[1], buf.shape[0]), buf, "raw", "RGBA",
                                 0, 1).convert("RGB")
        draw = ImageDraw.Draw(image)
        tips = pic["axes"][:, 1] + 0.08 * (pic["axes"][:, 1] - pic["axes"][:, 0])
        for j, (x, y) in enumerate(ax.transData.transform(tips)):
            draw.text((x, height_px - y), "xyz"[j], fill=drawing.AXIS_COLOURS[j], font=font,
                      anchor="mm")
        draw.text((8, height_px - 8), f"t = {tk:5.2f} s    impacts {int(seen.sum())}"
                  + (f"    h(S) = {hk:.3f} m" if hk is not None else ""), fill="black",
                  font=font, anchor="ld")
        frames.append(image)
    sample = np.vstack([np.asarray(f) for f in frames[:: max(1, len(frames) // 4)]])
    palette = Image.fromarray(sample).quantize(colors=128, method=Image.Quantize.MEDIANCUT)
    images = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    images[0].save(path, save_all=True, append_images=images[1:],
                   duration=int(round(1000 / FPS)), loop=0)
    return Path(path)

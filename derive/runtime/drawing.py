"""The geometry of the pictures of a run: an orthographic view, the body's outline and
principal sections as seen in it, its shadow on the plane, and the plane itself.

Everything is projected here with NumPy into screen coordinates, so matplotlib draws
plain 2-D lines and polygons (fast, and the body keeps its true shape: its outline is
made of the surface's support points, not sampled from a mesh).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import shapes

AXIS_COLOURS = ("#d62728", "#2ca02c", "#1f77b4")      # body x, y, z
PLANE_COLOUR = "#dfe7ef"
# the points P1, P2, ... (the one point P: the first), and the rotors
POINT_COLOURS = ("#ff7f0e", "#8c564b", "#e377c2", "#bcbd22", "#17becf", "#9467bd",
                 "#7f7f7f", "#393b79")
ROTOR_COLOUR = "#6a3d9a"
ROTOR_RADIUS = 0.45        # of the body's reach: a rotor drawn as a disc of this radius


def point_colour(j: int) -> str:
    return POINT_COLOURS[j % len(POINT_COLOURS)]


def point_label(j: int, n: int) -> str:
    """``P`` for the one point, ``P1``, ``P2``, ... for several."""
    return "P" if n == 1 else f"P{j + 1}"


def rotor_pictures(view, scene, r_O: np.ndarray, A: np.ndarray, psi) -> list:
    """Each rotor at one pose as screen polylines: the rim of a disc about its axis (its
    centre is no part of the scene: drawn at O; radius ROTOR_RADIUS of the body's reach)
    and a spoke at its angle psi from a reference direction fixed in the body, so that
    its turning shows.  ``psi``: one angle per rotor."""
    R = ROTOR_RADIUS * body_reach(scene)
    out = []
    for rotor, angle in zip(scene.rotors, psi):
        a = np.asarray(rotor.axis, dtype=float)
        helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = np.cross(a, helper)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        rim = R * (np.cos(_CIRCLE)[:, None] * e1 + np.sin(_CIRCLE)[:, None] * e2)
        spoke = R * np.array([[0.0, 0.0, 0.0], np.cos(angle) * e1 + np.sin(angle) * e2])
        out.append({"rim": view(r_O + rim @ A.T), "spoke": view(r_O + spoke @ A.T)})
    return out
DRAWN_BINS = 2000          # columns of time a curve is reduced to (a panel is ~500 pixels)


def drawn_rows(t: np.ndarray, *series: np.ndarray, bins: int = DRAWN_BINS) -> np.ndarray:
    """Indices of the rows that draw every series as all rows would at the resolution of
    a picture: in each of ``bins`` equal intervals of time, the first and last row and
    each series' lowest and highest (M4 aggregation), in time order.  All rows when there
    are no more than four per interval.  Millions of rows (a long or fast run) would take
    minutes to draw, or overflow matplotlib's renderer."""
    n = len(t)
    if n <= 4 * bins:
        return np.arange(n)
    t = np.asarray(t, dtype=float)
    edges = np.searchsorted(t, np.linspace(t[0], t[-1], bins + 1)[1:-1], side="left")
    starts = np.unique(np.r_[0, edges])
    starts = starts[starts < n]
    ends = np.r_[starts[1:], n] - 1
    of_row = np.repeat(np.arange(len(starts)), np.diff(np.r_[starts, n]))
    keep = [starts, ends]
    for y in series:
        y = np.asarray(y, dtype=float)
        for reduce in (np.fmin, np.fmax):
            extreme = reduce.reduceat(y, starts)
            hits = np.flatnonzero(y == extreme[of_row])
            _, first = np.unique(of_row[hits], return_index=True)
            keep.append(hits[first])
    return np.unique(np.concatenate(keep))


def body_surface(scene) -> tuple:
    """The surface drawn for the body: (its Shape of derive/shapes.py, its size numbers,
    whether the shape is real).  A body without a shape is drawn as its equivalent
    ellipsoid of inertia (the uniform solid ellipsoid of mass M with the moments J:
    a_x^2 = 5 (J_y + J_z - J_x) / (2 M), ...)."""
    if scene.shape in shapes.SHAPES:
        return shapes.of(scene.shape), tuple(scene.size), True
    Jx, Jy, Jz = scene.J
    sq = 2.5 / scene.M * np.array([Jy + Jz - Jx, Jx + Jz - Jy, Jx + Jy - Jz])
    axes = np.sqrt(np.maximum(sq, 0.0))
    return shapes.of("ellipsoid"), tuple(np.maximum(axes, 0.02 * axes.max())), False


def body_reach(scene) -> float:
    """The largest distance of the drawn surface from its centre."""
    shape, size, _ = body_surface(scene)
    return float(shape.reach(size))


@dataclass
class View:
    """An orthographic view from azimuth ``az`` and elevation ``el`` (degrees)."""
    az: float = -60.0
    el: float = 22.0

    @property
    def P(self) -> np.ndarray:
        """(2, 3): fixed axes to the screen (right, up)."""
        a, e = np.radians(self.az), np.radians(self.el)
        right = np.array([-np.sin(a), np.cos(a), 0.0])
        up = np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])
        return np.vstack([right, up])

    @property
    def towards(self) -> np.ndarray:
        """Unit vector from the scene towards the viewer."""
        a, e = np.radians(self.az), np.radians(self.el)
        return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])

    def __call__(self, pts: np.ndarray) -> np.ndarray:
        return np.asarray(pts) @ self.P.T


def view_for(points: np.ndarray) -> View:
    """A view in which the main horizontal travel of ``points`` (rows in time order) runs
    to the right, 30 degrees off the screen plane, seen from 22 degrees above (travel
    along +X gives matplotlib's default view, azimuth -60)."""
    flat = points[:, :2] - points[:, :2].mean(axis=0)
    if len(flat) < 2 or np.max(np.abs(flat)) < 1e-9:
        return View()
    _, _, vt = np.linalg.svd(flat, full_matrices=False)
    d = vt[0] if np.dot(vt[0], flat[-1] - flat[0]) >= 0 else -vt[0]
    az = np.degrees(np.arctan2(d[1], d[0])) - 60.0
    return View(az=float((az + 180.0) % 360.0 - 180.0), el=22.0)


_CIRCLE = np.linspace(0.0, 2.0 * np.pi, 73)
_UNIT = np.column_stack([np.cos(_CIRCLE), np.sin(_CIRCLE)])


def body_pictures(view: View, scene, r_O: np.ndarray, A: np.ndarray) -> dict:
    """Screen coordinates of the body at one pose: ``outline`` (closed), ``shadow`` on the
    plane Z = 0 (closed), the three principal sections split into their ``front`` and
    ``back`` halves (NaN-separated), the ``axes`` (3 segments O -> beyond the surface),
    and the ``centre`` of the shape.  Every curve is made of support points (the shape's
    points farthest along a direction, derive/shapes.py): the outline of directions in the
    screen plane (an orthographic view's silhouette), the shadow of horizontal ones, a
    principal section of directions in the body plane of two axes (seen where that
    direction, the surface's normal there, faces the viewer)."""
    shape, size, _ = body_surface(scene)
    c = r_O + A @ np.asarray(scene.center, dtype=float)

    def surface(d_fixed):                     # support points (fixed axes) of directions
        return c + shape.support_rows(d_fixed @ A, size) @ A.T

    out = {"centre": view(c), "outline": view(surface(_UNIT @ view.P))}
    horizontal = np.column_stack([_UNIT, np.zeros(len(_UNIT))])
    ring = surface(horizontal)
    ring[:, 2] = 0.0
    out["shadow"] = view(ring)
    towards_body = A.T @ view.towards
    front, back = [], []
    for i, j in ((1, 2), (2, 0), (0, 1)):
        u = np.zeros((len(_CIRCLE), 3))
        u[:, i], u[:, j] = _UNIT[:, 0], _UNIT[:, 1]
        screen = view(c + shape.support_rows(u, size) @ A.T)
        seen = u @ towards_body >= 0.0
        f, b = screen.copy(), screen.copy()
        f[~seen], b[seen] = np.nan, np.nan
        front.append(np.vstack([f, [np.nan, np.nan]]))
        back.append(np.vstack([b, [np.nan, np.nan]]))
    out["front"], out["back"] = np.vstack(front), np.vstack(back)
    tips = r_O + (1.3 * shape.reach(size) * A).T          # rows: the three axis ends
    out["axes"] = np.stack([np.vstack([view(r_O), view(tip)]) for tip in tips])
    out["axis_depth"] = (tips - r_O) @ view.towards
    return out


def nice_step(span: float, target: int = 6) -> float:
    raw = max(span, 1e-12) / target
    mag = 10.0 ** np.floor(np.log10(raw))
    for k in (1, 2, 2.5, 5, 10):
        if k * mag >= raw:
            return k * mag
    return 10 * mag


def plane_pictures(view: View, xlim: tuple, ylim: tuple) -> tuple[np.ndarray, list]:
    """The plane Z = 0 over a rectangle: its screen polygon and grid lines."""
    (x0, x1), (y0, y1) = xlim, ylim
    corners = np.array([[x0, y0, 0], [x1, y0, 0], [x1, y1, 0], [x0, y1, 0]], dtype=float)
    step = nice_step(max(x1 - x0, y1 - y0))
    lines = []
    for x in np.arange(np.ceil(x0 / step) * step, x1 + 1e-12, step):
        lines.append(view(np.array([[x, y0, 0.0], [x, y1, 0.0]])))
    for y in np.arange(np.ceil(y0 / step) * step, y1 + 1e-12, step):
        lines.append(view(np.array([[x0, y, 0.0], [x1, y, 0.0]])))
    return view(corners), lines


def lowest_points(scene, r_O: np.ndarray, A: np.ndarray) -> np.ndarray:
    """Positions (fixed axes) of the lowest point S for poses along rows."""
    shape, size, _ = body_surface(scene)
    s = shape.lowest_rows(A[:, 2, :], scene.center, size)     # n: the vertical, body axes
    return r_O + np.einsum("nij,nj->ni", A, s)


def scene_extent(scene, mo) -> tuple[tuple, tuple, float]:
    """The plane's rectangle (x, y limits) around the motion, and the body's reach."""
    reach = float(np.linalg.norm(scene.center)) + body_reach(scene) * 1.3
    pts = np.vstack([mo.r_O, *mo.r_points])
    lo, hi = pts[:, :2].min(axis=0) - reach, pts[:, :2].max(axis=0) + reach
    span = max(hi - lo)
    mid = 0.5 * (lo + hi)
    # a square-ish patch: the shorter side at least half the longer one
    half = np.maximum(0.5 * (hi - lo), 0.25 * span)
    return (mid[0] - half[0], mid[0] + half[0]), (mid[1] - half[1], mid[1] + half[1]), reach

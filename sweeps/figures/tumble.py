"""Figures of the tumbling planner (matplotlib, Agg backend).

* :func:`plot_development` draws the plane development of a polyhedron rooted
  at a face (Marigo & Bicchi, Fig. 3): every face's polygon placed in the
  plane by tumbling from its parent in a breadth-first tree, labelled with
  its face number, corners labelled with the caller's vertex indices.
* :func:`plot_reachable` draws the reachable lattice of positions around the
  start (Fig. 2) with its basis ``X1, X2``.
* :func:`plot_plan` draws the footprints (the face on the plane) along a
  tumble plan, replayed with the exact kernel.

Drawing only: the mathematics (developments, footprints, kernel replays,
lattice enumeration sizes) lives in :mod:`planning.tumbling.development`,
:mod:`planning.tumbling.trajectory` and :mod:`planning.tumbling.reachability`.

Conventions as in :mod:`kernels.polyhedron`: a configuration
``(x, y, theta, face)`` puts ``face`` on the plane with its frame at world
``(x, y)`` and heading ``theta``; a face-frame point ``q`` is at
``R(theta) q + (x, y)``.  Metres, radians.  No I/O beyond ``savefig`` of the
path given.
"""
from __future__ import annotations

import math
from fractions import Fraction
from typing import Mapping, Optional

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import FancyArrowPatch, Patch, Polygon as PolyPatch  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from kernels import rot2_np, Polyhedron
from planning import (development_poses, face_footprint, pose3, lattice_count_bound,
                      radius_for_count, reduced_basis, plan_trajectory, quiet_polyhedron,
                      sample_reached_positions)

START_COLOR = "tab:blue"
GOAL_COLOR = "tab:green"
FINAL_COLOR = "tab:orange"
MID_COLOR = "0.45"

__all__ = ["plot_development", "plot_reachable", "plot_plan", "MAX_DRAWN_POINTS"]


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------
def _unwrap_part(obj):
    """(Polyhedron, analysis or None, name) from an analysis, a Polyhedron, a
    PartFile or a vertex array."""
    if hasattr(obj, "polyhedron") and isinstance(getattr(obj, "polyhedron"), Polyhedron):
        return obj.polyhedron, obj, ""
    if isinstance(obj, Polyhedron):
        return obj, None, ""
    if hasattr(obj, "vertices") and hasattr(obj, "kind"):  # PartFile
        if obj.kind != "polyhedron":
            raise ValueError(f"kind: a plane development needs a polyhedron part, got {obj.kind!r}")
        return quiet_polyhedron(obj.vertices, obj.com), None, obj.name
    return quiet_polyhedron(obj, None), None, ""


def _fmt_frac_pi(x) -> str:
    """A rotation angle given as a Fraction of pi (or a float in rad)."""
    if isinstance(x, Fraction):
        if x == 0:
            return "0"
        num = "" if x.numerator == 1 else ("-" if x.numerator == -1 else str(x.numerator))
        return f"{num}π" + ("" if x.denominator == 1 else f"/{x.denominator}")
    try:
        return f"{float(x):.4g} rad"
    except (TypeError, ValueError):
        return str(x)


def _vec2(v) -> np.ndarray:
    return np.array([float(v[0]), float(v[1])], dtype=float)


def _limits(ax, pts: np.ndarray, pad_frac: float = 0.06, min_pad: float = 0.0) -> None:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = pad_frac * float(np.max(hi - lo)) + min_pad
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    _ticks(ax)


def _ticks(ax) -> None:
    ax.xaxis.set_major_locator(MaxNLocator(nbins=6))
    ax.yaxis.set_major_locator(MaxNLocator(nbins=8))


# --------------------------------------------------------------------------
# Plane development (Fig. 3)
# --------------------------------------------------------------------------
def plot_development(polyhedron_or_analysis, path, root: Optional[int] = None,
                     title: Optional[str] = None, name: str = "", dpi: int = 150) -> dict:
    """Draw the plane development rooted at a face (paper Fig. 3); save to ``path``.

    Every face's polygon is drawn at the planar pose of its copy in the
    development: taken from ``analysis.development`` when an analysis of
    :mod:`planning.tumbling.planner` is given (rooted at its start face),
    otherwise computed here by :func:`development_poses`.  Each polygon is
    labelled with its face number at its centroid, its corners with the
    caller's vertex indices (inside the polygon, near the corner); the root
    face is highlighted, thin grey lines join each face's centroid to its
    parent's in the unfolding tree (the transit paths).  Copies may overlap:
    a development is an immersion, not necessarily an embedding.

    Args:
      polyhedron_or_analysis: a ``TumbleAnalysis``, a
        :class:`~kernels.polyhedron.Polyhedron`, a
        :class:`~sweeps.partfile.PartFile` or an (m, 3) vertex array.
      path: file to write (PNG or any matplotlib format).
      root: root face (default: the analysis' start face, else 0).
      title: optional title.
      name: the part's name for the default title.

    Returns:
      ``{face: (x, y, theta)}``, the poses drawn.
    """
    poly, analysis, name0 = _unwrap_part(polyhedron_or_analysis)
    name = name or name0
    parent = None
    poses = None
    if analysis is not None and getattr(analysis, "development", None) is not None:
        dev = analysis.development
        items = dev.items() if isinstance(dev, Mapping) else enumerate(dev)
        poses = {int(f): pose3(p) for f, p in items}
        zero = [f for f, p in poses.items() if np.allclose(p, 0.0, atol=1e-12)]
        guess = getattr(analysis, "start_face", zero[0] if zero else 0)
        if root is None:
            root = int(guess)
        if root != int(guess) or len(poses) != poly.n_faces:
            poses = None
        else:
            tp = getattr(analysis, "transit_paths", None)
            if isinstance(tp, Mapping):
                parent = {root: None}
                for f, p in tp.items():
                    p = [int(v) for v in p]
                    if int(f) != root and p:
                        chain = ([root] + p) if p[0] != root else p
                        parent[int(f)] = chain[-2] if len(chain) >= 2 else root
    if root is None:
        root = 0
    if poses is None:
        poses, parent = development_poses(poly, root)
    if parent is None or len(parent) != poly.n_faces:
        _, parent = development_poses(poly, root)

    diam = float(np.max(np.linalg.norm(poly.vertices[:, None] - poly.vertices[None], axis=-1)))
    fig, ax = plt.subplots(figsize=(8.5, 8.0))
    cmap = plt.get_cmap("tab20")
    allpts = []
    cents = {}
    for f in sorted(poses):
        w = face_footprint(poly, f, poses[f])
        allpts.append(w)
        c = w.mean(axis=0)
        cents[f] = c
        is_root = f == root
        fc = START_COLOR if is_root else cmap(f % 20)
        ax.add_patch(PolyPatch(w, closed=True, facecolor=fc, alpha=0.45 if is_root else 0.18,
                               edgecolor="none", zorder=2))
        ax.add_patch(PolyPatch(w, closed=True, fill=False, edgecolor="k" if is_root else "0.2",
                               lw=2.2 if is_root else 1.0, zorder=3))
        ax.text(c[0], c[1], f"F{f}" + ("\n(root)" if is_root else ""), ha="center", va="center",
                fontsize=10 if is_root else 9, fontweight="bold",
                color="navy" if is_root else "k", zorder=6)
        # corner labels: caller vertex indices, pulled toward the centroid
        for v, p in zip(poly.face_cycles[f], w):
            q = p + 0.22 * (c - p)
            ax.text(q[0], q[1], str(v), ha="center", va="center", fontsize=7, color="firebrick",
                    zorder=6)
        ax.plot(*poses[f][:2], "k.", ms=3, zorder=5)
    for f, p in parent.items():
        if p is not None and f in cents and p in cents:
            ax.plot([cents[p][0], cents[f][0]], [cents[p][1], cents[f][1]], color="0.55", lw=0.8,
                    ls="--", zorder=4)
    pts = np.concatenate(allpts)
    _limits(ax, pts, 0.04, 0.02 * diam)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, lw=0.4, alpha=0.4)
    handles = [Patch(facecolor=START_COLOR, alpha=0.5, edgecolor="k", label=f"root face F{root} at (0, 0, 0)"),
               Line2D([], [], color="0.55", ls="--", lw=0.8, label="unfolding tree (transit paths)"),
               Line2D([], [], ls="", marker="$7$", color="firebrick", label="caller vertex index"),
               Line2D([], [], ls="", marker=".", color="k", label="face-frame origin (CoM projected)")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    if title is None:
        title = (f"Plane development{' of ' + name if name else ''}: {poly.n_faces} faces, "
                 f"{poly.n_vertices} vertices, rooted at F{root}")
    ax.set_title(title, fontsize=11)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return poses


# --------------------------------------------------------------------------
# Reachable lattice (Fig. 2)
# --------------------------------------------------------------------------
#: Most lattice points drawn; beyond, the lattice is shown in a zoomed panel.
MAX_DRAWN_POINTS = 20_000


def _fmt_angle(x) -> str:
    """A rotation step given as a Fraction of pi: exact when short, else in rad."""
    if isinstance(x, Fraction) and x.denominator > 10**6:
        return f"{float(x) * math.pi:.3g} rad (π/{float(x.denominator):.3g})" \
            if x.numerator == 1 else f"{float(x) * math.pi:.3g} rad"
    return _fmt_frac_pi(x)


def _unit_scale(r: float) -> tuple[float, str]:
    """A power-of-ten unit for an axis spanning about ``r`` metres."""
    if r >= 1e-3:
        return 1.0, "m"
    e = int(math.floor(math.log10(r)))
    return 10.0 ** e, f"1e{e} m"


def _draw_basis(ax, basis, scale: float, handles: Optional[list], view: float):
    """Arrows X1, X2 from the origin (axis units = ``scale`` metres); an arrow longer
    than ``view`` (axis units) is cut at the edge of the view and its label says so."""
    cols = ("tab:red", "tab:purple")
    for k, X in enumerate(list(basis)[:2]):
        X = _vec2(X)
        Xs = X / scale
        n = float(np.linalg.norm(Xs))
        label = f" X{k + 1}"
        if n > view:
            Xs = Xs * (0.95 * view / n)
            label += " (continues)"
        # patches and texts clipped to the axes: a basis vector far outside the view
        # (a very skewed lattice) must not blow up the saved figure's bounding box
        ax.add_patch(FancyArrowPatch((0.0, 0.0), tuple(Xs), arrowstyle="-|>", color=cols[k], lw=2.0,
                                     mutation_scale=16, shrinkA=0, shrinkB=0, zorder=6))
        ax.text(Xs[0], Xs[1], label, color=cols[k], fontsize=10, fontweight="bold",
                ha="left", va="bottom", zorder=7, clip_on=True)
        if handles is not None:
            handles.append(Line2D([], [], color=cols[k], lw=2,
                                  label=f"X{k + 1} = ({X[0]:.4g}, {X[1]:.4g}) m"))


def plot_reachable(analysis, path, radius: float, title: Optional[str] = None,
                   name: str = "", n_walks: int = 1000, dpi: int = 150) -> np.ndarray:
    """Draw the reachable positions around the start (paper Fig. 2); save to ``path``.

    Main panel, a disc of ``radius`` about the start (the start face's frame
    at ``(0, 0, 0)``; coordinates in that frame):

    * black dots: the lattice ``k1 X1 + k2 X2`` of positions the start face
      reaches with its heading unchanged (``analysis.reachable_points``;
      exact for a discrete class, the planner's ``tau_g`` approximation for
      a dense one), with the basis ``X1, X2`` as arrows;
    * grey dots: positions (any heading) with the start face down reached by
      ``n_walks`` random tumble walks replayed by the exact kernel
      (:func:`sample_reached_positions`): a lattice-like pattern for a
      discrete class, a filling cloud for a dense one (as in Fig. 2);
    * the start face's footprint, the centre of ``R̄`` when it lies in view.

    When the lattice has more than ``MAX_DRAWN_POINTS`` points within
    ``radius`` (a dense class: the mesh is far finer than the figure), a
    second panel zooms on the start to show the lattice points and the basis
    at their own scale.  The title gives the reachable class, the mesh area
    ``Delta`` and the rotation steps.

    Returns:
      The (N, 2) lattice points drawn (in metres).
    """
    poly = analysis.polyhedron
    radius = float(radius)
    if not (math.isfinite(radius) and radius > 0):
        raise ValueError(f"radius: must be a positive number of metres, got {radius}")
    root = int(getattr(analysis, "start_face", 0))
    basis = getattr(analysis, "lattice_basis", None)
    area = float(getattr(analysis, "mesh_area", float("nan")) or float("nan"))
    est = math.pi * radius ** 2 / area if area > 0 else math.inf
    b1 = b2 = None
    if basis is not None and area > 0:
        b1, b2 = reduced_basis(basis)
    zoom = b1 is None or not lattice_count_bound(radius, b1, b2) <= MAX_DRAWN_POINTS
    if zoom:
        fig, (ax, zx) = plt.subplots(1, 2, figsize=(14.5, 7.2),
                                     gridspec_kw=dict(width_ratios=[1, 1], wspace=0.28))
    else:
        fig, ax = plt.subplots(figsize=(8.5, 8.0))
    samples = sample_reached_positions(poly, root, radius, n_walks=n_walks) if n_walks > 0 \
        else np.zeros((0, 2))
    ax.add_patch(plt.Circle((0.0, 0.0), radius, fill=False, color="0.6", ls=":", lw=1.0, zorder=1))
    handles = []
    if len(samples):
        ax.scatter(samples[:, 0], samples[:, 1], s=3.0, color="0.5", lw=0, zorder=2, alpha=0.7)
        handles.append(Line2D([], [], ls="", marker="o", color="0.55", ms=3,
                              label=f"F{root} down, any heading: {len(samples)} visits by "
                                    f"{n_walks} random walks"))
    pts = np.zeros((0, 2))
    if not zoom:
        pts = np.asarray(analysis.reachable_points(radius, max_points=10**9),
                         dtype=float).reshape(-1, 2)
        ms = float(np.clip(1500.0 / max(len(pts), 1) ** 0.75, 0.8, 30.0))
        ax.scatter(pts[:, 0], pts[:, 1], s=ms, color="k", lw=0, zorder=3)
        handles.append(Line2D([], [], ls="", marker="o", color="k", ms=4,
                              label=f"lattice k1 X1 + k2 X2 (heading unchanged): {len(pts)} points"))
        if basis is not None:
            _draw_basis(ax, basis, 1.0, handles, 1.08 * radius)
    else:
        # covering radius of the lattice <= (|b1| + |b2|) / 2 in a reduced basis
        spacing = 0.5 * (float(np.linalg.norm(b1)) + float(np.linalg.norm(b2))) \
            if b1 is not None else float("nan")
        ax.add_patch(plt.Circle((0.0, 0.0), radius, color="k", alpha=0.06, lw=0, zorder=0))
        handles.append(Patch(facecolor="k", alpha=0.12,
                             label=f"lattice (heading unchanged): ~{est:.2g} points, every point "
                                   f"within {spacing:.2g} m of one (zoom at right)"))
    w = face_footprint(poly, root, (0.0, 0.0, 0.0))
    ax.add_patch(PolyPatch(w, closed=True, facecolor=START_COLOR, alpha=0.35, edgecolor=START_COLOR,
                           lw=1.5, zorder=4))
    ax.plot([0.0], [0.0], "o", color=START_COLOR, ms=5, zorder=5)
    handles.insert(0, Patch(facecolor=START_COLOR, alpha=0.45, label=f"start face F{root} at (0, 0, 0)"))
    centre = getattr(analysis, "rbar_centre", None)
    if centre is not None:
        try:
            c = _vec2(centre)
        except (TypeError, ValueError, IndexError):
            c = None
        if c is not None and np.all(np.isfinite(c)) and np.linalg.norm(c) <= radius:
            ax.plot(*c, marker="*", color="tab:orange", ms=12, ls="", zorder=6)
            handles.append(Line2D([], [], ls="", marker="*", color="tab:orange", ms=10,
                                  label="centre of R̄ (rotation by β̄)"))
    lim = 1.08 * radius
    ax.set_xlim(-lim, lim)
    ax.set_ylim(-lim, lim)
    _ticks(ax)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m] (start face frame)")
    ax.set_ylabel("y [m]")
    ax.grid(True, lw=0.4, alpha=0.4)
    if zoom:
        if b1 is None:
            raise ValueError("analysis: the translation lattice is degenerate (rank < 2 or zero "
                             "mesh area); nothing to draw")
        bl = max(float(np.linalg.norm(_vec2(X))) for X in list(basis)[:2])
        # enough to show the basis, but never more than ~MAX_DRAWN_POINTS points
        rz = radius_for_count(MAX_DRAWN_POINTS / 4.0, b1, b2, 1.15 * bl)
        rz = max(rz, radius_for_count(300.0, b1, b2, radius))
        pts = np.asarray(analysis.reachable_points(rz, max_points=10**9), dtype=float).reshape(-1, 2)
        scale, unit = _unit_scale(rz)
        ps = pts / scale
        zx.scatter(ps[:, 0], ps[:, 1], s=float(np.clip(1500.0 / max(len(ps), 1) ** 0.75, 0.8, 30.0)),
                   color="k", lw=0, zorder=3)
        zx.add_patch(plt.Circle((0.0, 0.0), rz / scale, fill=False, color="0.6", ls=":", lw=1.0))
        zh = [Line2D([], [], ls="", marker="o", color="k", ms=4,
                     label=f"lattice points within {rz:.3g} m: {len(pts)}")]
        if basis is not None:
            _draw_basis(zx, basis, scale, zh, 1.08 * rz / scale)
        zx.plot([0.0], [0.0], "o", color=START_COLOR, ms=5, zorder=5)
        zl = 1.08 * rz / scale
        zx.set_xlim(-zl, zl)
        zx.set_ylim(-zl, zl)
        zx.set_aspect("equal")
        _ticks(zx)
        zx.set_xlabel(f"x [{unit}]")
        zx.set_ylabel(f"y [{unit}]")
        zx.grid(True, lw=0.4, alpha=0.4)
        zx.set_title(f"zoom on the start: the lattice (mesh Δ = {area:.3g} m²)", fontsize=10)
        zx.legend(handles=zh, loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=8,
                  frameon=False)
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=8,
                  frameon=False)
    else:
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
                  frameon=False)
    if title is None:
        cls = getattr(analysis, "reachable_class", "?")
        beta = getattr(analysis, "beta_bar", None)
        small = getattr(analysis, "smallest_rotation", None)
        head = f"{name + ': ' if name else ''}reachable set {cls}"
        if cls != "discrete":
            tg = getattr(analysis, "tau_g_used", None)
            head += " (drawn: the planner's lattice approximation" + \
                (f", tau_g = {tg:g})" if isinstance(tg, (int, float)) and tg else ")")
        parts = [f"mesh area Δ = {area:.3g} m²"]
        if beta is not None:
            parts.append(f"β̄ = {_fmt_angle(beta)}")
        if small is not None and small != beta:
            parts.append(f"smallest rotation {_fmt_angle(small)}")
        title = head + "\n" + ", ".join(parts)
    (fig.suptitle if zoom else ax.set_title)(title, fontsize=11)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return pts


# --------------------------------------------------------------------------
# Plan footprints
# --------------------------------------------------------------------------
def _fmt_cfg(c) -> str:
    def z(v):  # round-off (|v| < 1e-12 m) shown as 0
        v = float(v)
        return 0.0 if abs(v) < 1e-12 else v
    return (f"({z(c[0]):.4g} m, {z(c[1]):.4g} m, "
            f"{round(math.degrees(float(c[2])), 1) + 0.0:.1f}°, F{int(c[3])})")


def _heading(ax, poly, face, pose, color, scale):
    """Short arrow along the face frame's x-axis (the heading theta)."""
    o = np.asarray(pose[:2], dtype=float)
    d = rot2_np(float(pose[2])) @ np.array([scale, 0.0])
    ax.annotate("", xy=o + d, xytext=o,
                arrowprops=dict(arrowstyle="-|>", color=color, lw=1.4, shrinkA=0, shrinkB=0,
                                mutation_scale=10), zorder=8)


def plot_plan(plan, path, title: Optional[str] = None, name: str = "",
              dpi: int = 150) -> np.ndarray:
    """Draw the footprints along a tumble plan; save to ``path``.

    The plan's tumbles are replayed from ``plan.start`` with
    :func:`kernels.tumble.replay_trajectory`; the face on the plane after
    every tumble is drawn light grey, the start (blue), the goal (green) and
    the predicted final configuration (orange, dashed) highlighted with an
    arrow along their face frame's x-axis (the heading), and a line joins the
    footprints' centroids in order.

    Returns:
      The (L+1, 4) replayed configurations ``(x, y, theta, face)``.
    """
    poly, cfgs, ok = plan_trajectory(plan)
    diam = float(np.max(np.linalg.norm(poly.vertices[:, None] - poly.vertices[None], axis=-1)))
    L = len(cfgs) - 1
    fig, ax = plt.subplots(figsize=(9.5, 7.5))
    polys = [face_footprint(poly, int(c[3]), c[:3]) for c in cfgs]
    if L > 0:
        alpha = float(np.clip(3.0 / math.sqrt(L), 0.04, 0.25))
        ax.add_collection(PolyCollection(polys[1:], facecolors=MID_COLOR, edgecolors="0.3",
                                         linewidths=0.4, alpha=alpha, zorder=2))
    cents = np.array([p.mean(axis=0) for p in polys])
    ax.plot(cents[:, 0], cents[:, 1], color="0.25", lw=0.8, zorder=3, alpha=0.8)
    if L <= 40:
        for i, c in enumerate(cents[1:], start=1):
            ax.text(c[0], c[1], str(i), fontsize=6, color="0.3", ha="center", va="center", zorder=4)
    goal = tuple(plan.goal)
    final = tuple(plan.predicted_final) if plan.predicted_final is not None else None
    wg = face_footprint(poly, int(goal[3]), goal[:3])
    ws = polys[0]
    ax.add_patch(PolyPatch(ws, closed=True, facecolor=START_COLOR, alpha=0.35, edgecolor=START_COLOR,
                           lw=1.8, zorder=5))
    ax.add_patch(PolyPatch(wg, closed=True, facecolor=GOAL_COLOR, alpha=0.30, edgecolor=GOAL_COLOR,
                           lw=1.8, zorder=5))
    span = np.concatenate(polys + [wg])
    arrow = max(0.25 * diam, 0.04 * float(np.max(np.ptp(span, axis=0))))
    _heading(ax, poly, int(plan.start[3]), plan.start, START_COLOR, arrow)
    _heading(ax, poly, int(goal[3]), goal, GOAL_COLOR, arrow)
    allpts = polys + [wg]
    handles = [Patch(facecolor=START_COLOR, alpha=0.5, label=f"start {_fmt_cfg(plan.start)}"),
               Patch(facecolor=GOAL_COLOR, alpha=0.5, label=f"goal {_fmt_cfg(goal)}")]
    if final is not None:
        wf = face_footprint(poly, int(final[3]), final[:3])
        ax.add_patch(PolyPatch(wf, closed=True, fill=False, edgecolor=FINAL_COLOR, lw=1.8, ls="--",
                               zorder=6))
        _heading(ax, poly, int(final[3]), final, FINAL_COLOR, 0.8 * arrow)
        allpts.append(wf)
        handles.append(Line2D([], [], color=FINAL_COLOR, ls="--", lw=1.8,
                              label=f"predicted final {_fmt_cfg(final)}"))
    handles += [Patch(facecolor=MID_COLOR, alpha=0.3, label=f"face on the plane after each tumble ({L})"),
                Line2D([], [], color="0.25", lw=0.8, label="path through footprint centroids"),
                Line2D([], [], color="k", lw=1.4, marker=">", ms=4, label="face-frame x-axis (heading)")]
    if L > 0 and (np.max(np.abs(cfgs[-1, :2] - np.asarray(final[:2] if final else cfgs[-1, :2]))) > 1e-6 * diam
                  or not ok):
        handles.append(Line2D([], [], ls="", label="warning: replay differs from predicted final"))
    _limits(ax, np.concatenate(allpts), 0.05, 0.1 * diam)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, lw=0.4, alpha=0.4)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    if title is None:
        err = getattr(plan, "error", None)
        err_s = f"{float(err):.3g}" if err is not None else "n/a"
        title = (f"{name + ': ' if name else ''}tumble plan: {plan.verdict}, {L} tumbles"
                 + (f" (paper's construction: {_fmt_count(plan.n_tumbles_paper)})"
                    if getattr(plan, "n_tumbles_paper", None) not in (None, L) else "")
                 + f", error {err_s} (eps {float(plan.eps):.3g})")
        if plan.verdict != "solved" and getattr(plan, "reason", ""):
            title += "\n" + _short(plan.reason, 110)
    ax.set_title(title, fontsize=10)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return cfgs


def _fmt_count(n) -> str:
    """A tumble count that may be astronomically large (a Python int)."""
    n = int(n)
    if n < 10**7:
        return str(n)
    digits = str(n)
    return f"~{digits[0]}.{digits[1:3]}e{len(digits) - 1}"


def _short(s: str, n: int) -> str:
    s = " ".join(str(s).split())
    return s if len(s) <= n else s[: n - 1] + "…"

"""Figures of the pushing planner (matplotlib, Agg backend).

* :func:`plot_plan` draws a pose plan like Akella & Mason's Figure 1: the part
  at the start, after every push and at the goal, and for every push the fence
  where it first touches the part, with an arrow as long as the push.
* :func:`plot_psd` draws the push stability diagram of a part for normal
  pushes (the paper's Figure 6 on its 90-degree line, unrolled): which stable
  edge every orientation ends on, the convergent and divergent orientations,
  and the maximum reorient and step angles of every stable edge.
  :func:`push_stability` computes its data.
* :func:`plot_funnel` draws a sensorless plan's push function (Goldberg's
  step function) with the orienting funnel on it: the possible headings
  before and after every orient push.

No I/O here beyond ``savefig`` of the path given.
"""
from __future__ import annotations

import math
from typing import Optional

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch, Polygon as PolyPatch  # noqa: E402

from kernels import rot2_np  # noqa: E402
from planning import (prepare_part, push_stability as planning_push_stability, PushOptions,  # noqa: E402
                      PushPart, PushPlan, PushStability, SensorlessPlan)
from sweeps.figures.plan_steps import mark_steps  # noqa: E402

START_COLOR = "tab:blue"
GOAL_COLOR = "tab:green"
MID_COLOR = "0.45"
# push colours: distinct from the start (blue), goal (green) and intermediate (grey) poses
PUSH_COLORS = ("tab:orange", "tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:olive",
               "tab:cyan", "navy", "darkgoldenrod", "maroon")


def _world(body: np.ndarray, pose) -> np.ndarray:
    """Body-frame points (relative to the centre of mass) placed at ``pose``."""
    return body @ rot2_np(float(pose[2])).T + np.asarray(pose[:2], dtype=float)


# --------------------------------------------------------------------------
# Plan figure (Figure 1)
# --------------------------------------------------------------------------
def _fence(world: np.ndarray, d: np.ndarray, extent: float):
    """The fence before a push along ``d``: the part's support line on its
    trailing side (normal ``-d``).  Returns (segment (2, 2), contact centre)."""
    s = world @ d
    smin = float(s.min())
    touching = world[s - smin <= 1e-9 * max(extent, 1e-12)]
    centre = touching.mean(axis=0)
    perp = np.array([-d[1], d[0]])
    t = (world - centre) @ perp
    pad = 0.25 * extent
    lo, hi = float(t.min()) - pad, float(t.max()) + pad
    return np.stack([centre + lo * perp, centre + hi * perp]), centre


def plot_plan(plan: PushPlan, path, title: Optional[str] = None, name: Optional[str] = None,
              dpi: int = 150, outline: tuple = ()) -> None:
    """Draw a pose plan (the paper's Figure 1) and save it to ``path``.

    The part's outline (its convex hull) is drawn at the start (blue, pose 0),
    after every push (grey, numbered 1, 2, ...), and at the goal (green, the
    last pose); the black dot is the centre of mass and the thick side of
    every outline is the edge the plan's reorient pushes land.  For push ``i``
    the fence is drawn where it first touches the part, i.e. the part's
    support line on the trailing side at the pose before the push, and the
    arrow from the contact along the push direction is as long as the push,
    so its tip lies on the fence's final position.

    Args:
      plan: a :class:`~planning.pushing.plan.PushPlan`.
      path: PNG (or any matplotlib format) to write.
      title: optional title; default: part class, plan class, pushes, distance.
      name: the part's name, put in front of the default title.
      dpi: resolution.
      outline: the part's real outline, loops in the frame of
        ``plan.vertices`` (m; outer first, then holes: a CAD part's
        :attr:`~sweeps.partfile.PartFile.loops`): drawn inside each hull at
        the start and the goal (the hull, which the fence touches, stays the
        outline drawn).
    """
    poly = plan.nominal_part()
    body = poly.body
    hull = poly.hull_index
    extent = float(np.max(np.linalg.norm(body[:, None] - body[None], axis=-1)))
    poses = [np.asarray(plan.start, float)] + [np.asarray(p.pose_after, float) for p in plan.pushes]
    mark = plan.reorient_edge or (plan.pushes[0].edge if plan.pushes else None)
    mark_idx = None
    if mark is not None:
        a, b = hull.index(mark[0]), hull.index(mark[1])
        mark_idx = (a, b)

    fig, ax = plt.subplots(figsize=(9.5, 7.0))
    handles = []
    extra_pts = []  # fence ends and arrow tips, for the axis limits
    last = len(poses) - 1
    for i, pose in enumerate(poses):
        w = _world(body, pose)
        if i == 0:
            fc, ec, alpha, z, lw = START_COLOR, START_COLOR, 0.35, 4, 1.6
        elif i == last:
            fc, ec, alpha, z, lw = GOAL_COLOR, GOAL_COLOR, 0.35, 4, 1.6
        else:
            fc, ec, alpha, z, lw = MID_COLOR, MID_COLOR, 0.10, 3, 1.0
        ax.add_patch(PolyPatch(w, closed=True, facecolor=fc, alpha=alpha, edgecolor="none", zorder=z))
        ax.add_patch(PolyPatch(w, closed=True, fill=False, edgecolor=ec, lw=lw, zorder=z + 0.1))
        if outline and i in (0, last):
            for loop in outline:
                lw_ = _world(np.asarray(loop, float) - np.asarray(poly.com), pose)
                ax.add_patch(PolyPatch(lw_, closed=True, fill=False, edgecolor="k", lw=0.8,
                                       zorder=z + 0.3))
        if mark_idx is not None:
            ax.plot(w[list(mark_idx), 0], w[list(mark_idx), 1], color=ec, lw=lw + 2.2,
                    solid_capstyle="butt", zorder=z + 0.2)
        ax.plot(pose[0], pose[1], "o", color="k", ms=2.5, zorder=6)
        ax.annotate(str(i), (pose[0], pose[1]), xytext=(4, 4), textcoords="offset points",
                    fontsize=9, color=ec if i in (0, last) else "0.25", zorder=7,
                    fontweight="bold" if i in (0, last) else "normal")

    for i, push in enumerate(plan.pushes):
        d = np.asarray(push.direction, float)
        d = d / np.linalg.norm(d)
        w = _world(body, poses[i])
        seg, c0 = _fence(w, d, extent)
        col = PUSH_COLORS[i % len(PUSH_COLORS)]
        extra_pts += [seg, (c0 + push.distance * d)[None]]
        ax.plot(seg[:, 0], seg[:, 1], color=col, lw=3.2, solid_capstyle="butt", zorder=5)
        # hatch marks on the fence's back side
        back = -d * 0.06 * extent
        for t in np.linspace(0.0, 1.0, 7):
            p = seg[0] + t * (seg[1] - seg[0])
            ax.plot([p[0], p[0] + back[0]], [p[1], p[1] + back[1]], color=col, lw=1.0, zorder=5)
        ax.annotate("", xy=c0 + push.distance * d, xytext=c0,
                    arrowprops=dict(arrowstyle="-|>", color=col, lw=1.3, shrinkA=0, shrinkB=0,
                                    mutation_scale=12, alpha=0.85), zorder=5)
        label = f"push {i + 1}: {push.kind} {push.distance * 1000:.4g} mm"
        if push.kind == "reorient":
            label += f", pivot {push.contact_vertex}"
        label += f" -> edge {list(push.edge)}"
        handles.append(Line2D([], [], color=col, lw=3, label=label))

    pts = np.concatenate([_world(body, p) for p in poses] + extra_pts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = 0.08 * max(float(np.max(hi - lo)), extent) + 0.3 * extent
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, lw=0.4, alpha=0.5)
    head = [Patch(facecolor=START_COLOR, alpha=0.5, label=f"start (pose 0) {_fmt_pose(plan.start)}")]
    if last > 1:
        head.append(Patch(facecolor=MID_COLOR, alpha=0.25, label="after push i (pose i)"))
    head.append(Patch(facecolor=GOAL_COLOR, alpha=0.5, label=f"goal (pose {last}) {_fmt_pose(plan.goal)}"))
    if mark is not None:
        head.append(Line2D([], [], color="k", lw=3.5, label=f"edge {list(mark)} (thick side)"))
    if outline:
        head.append(Line2D([], [], color="k", lw=0.8,
                           label="the part's outline (CAD; holes inside); coloured: its hull"))
    ax.legend(handles=head + handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8,
              frameon=False, title="fence at the start of each push; arrow = push distance",
              title_fontsize=8)
    if title is None:
        pushes = f"{plan.n_pushes} push{'es' if plan.n_pushes != 1 else ''}"
        title = (f"{name + ': ' if name else ''}{plan.object_class} part, {plan.plan_class} plan: "
                 f"{pushes} ({plan.n_reorients} reorient), total {plan.total_distance:.4g} m")
    ax.set_title(title, fontsize=11)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)


def _fmt_pose(p) -> str:
    return f"({p[0]:.3g} m, {p[1]:.3g} m, {math.degrees(p[2]):.1f}°)"


# --------------------------------------------------------------------------
# Push stability diagram (Figure 6, normal pushes)
# --------------------------------------------------------------------------
def _as_part(part_or_vertices, margin_deg: float, com) -> tuple[PushPart, str]:
    if isinstance(part_or_vertices, PushPart):
        return part_or_vertices, ""
    name = ""
    vertices = part_or_vertices
    if hasattr(part_or_vertices, "vertices") and hasattr(part_or_vertices, "kind"):  # PartFile
        if part_or_vertices.kind != "polygon":
            raise ValueError(f"kind: the push stability diagram needs a polygon part, got "
                             f"{part_or_vertices.kind!r}")
        name = part_or_vertices.name
        vertices = part_or_vertices.vertices
        com = part_or_vertices.com if com is None else com
    elif hasattr(part_or_vertices, "vertices") and hasattr(part_or_vertices, "com"):  # Polygon
        vertices, com = part_or_vertices.vertices, part_or_vertices.com if com is None else com
    return prepare_part(np.asarray(vertices, dtype=float), com, margin_deg), name


def push_stability(part_or_vertices, margin_deg: float = PushOptions.margin_deg, com=None,
                   n_grid: int = 3600):
    """:func:`planning.pushing.stability.push_stability` of a part given as a
    :class:`~planning.PushPart`, a :class:`~sweeps.partfile.PartFile`, a
    :class:`kernels.polygon.Polygon` or an (m, 2) vertex array (metres)."""
    part, _ = _as_part(part_or_vertices, margin_deg, com)
    return planning_push_stability(part, n_grid=n_grid)


def _runs(values: np.ndarray):
    """Contiguous runs (start index, stop index, value) of a 1-D array."""
    change = np.flatnonzero(np.diff(values)) + 1
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [len(values)]])
    return [(int(a), int(b), int(values[a])) for a, b in zip(starts, stops)]


def _span(ax, a: float, b: float, y: float, color, lw: float, tick: float, alpha=1.0):
    """Horizontal bracket from a to b degrees (a < b, may leave [0, 360]) at height
    y, wrapped into [0, 360], with end ticks at its true ends only."""
    pieces = []
    lo, hi = a, b
    while lo < 0:
        lo += 360.0
        hi += 360.0
    if hi <= 360.0:
        pieces.append((lo, hi))
    else:
        pieces += [(lo, 360.0), (0.0, hi - 360.0)]
    for p, q in pieces:
        ax.plot([p, q], [y, y], color=color, lw=lw, solid_capstyle="butt", alpha=alpha)
    for x in (lo % 360.0 if lo != 360.0 else 360.0, hi - 360.0 if hi > 360.0 else hi):
        ax.plot([x, x], [y - tick, y + tick], color=color, lw=1.2, alpha=alpha)


def plot_psd(part_or_vertices, path, margin_deg: float = PushOptions.margin_deg, com=None, title: Optional[str] = None,
             name: Optional[str] = None, n_grid: int = 3600, dpi: int = 150,
             plan: Optional[PushPlan] = None) -> PushStability:
    """Draw the push stability diagram for normal pushes and save it to ``path``.

    Horizontal axis: the part's orientation relative to the fence, 0..360
    degrees (fence along x below the part, pushing in +y; see
    :class:`PushStability`).  Top panel: the distance from the centre of mass
    to the fence (its local minima are the stable edges), over colour bands
    showing on which stable edge a long normal push from each orientation
    ends (capture ranges, from the exact replay); convergent orientations
    (stable edges flush) as double lines, divergent ones (centre of mass above
    the touching vertex) as single bold lines, unstable edges flush as dotted
    lines.  A marginal edge (the foot of the centre of mass at one of its
    ends) is not stable: flush, the part balances on that end, an unstable
    equilibrium, drawn as a red cross on the curve; the pushes that reach it
    are coloured by where the part rolls on (an arbitrarily small perturbation
    decides, :mod:`planning.pushing.stability`) and hatched (a centre of mass
    a hair inside the edge would stop them on it).  Bottom panel, one row per
    stable edge: the maximum CW and CCW reorient angles (light brackets) and the step angles after the margin
    (dark brackets; for a slip-aware plan at most the sticking limit).  With a
    ``plan``, its chosen reorient steps are marked on their edges' rows: an
    arrow from the orientation relative to the fence where each reorient push
    starts to where its edge lands, numbered by the push's index in the plan.
    Edges are labelled by caller vertex-index pairs.

    Args:
      part_or_vertices: as :func:`push_stability`.
      path: file to write.
      margin_deg, com, n_grid: as :func:`push_stability`.
      title: optional title.
      name: the part's name for the default title (default: a PartFile's name).
      plan: optional :class:`~planning.PushPlan` of this part whose reorient
        steps are marked (the part's tables then follow the plan's settings).

    Returns:
      The :class:`PushStability` data drawn.
    """
    if plan is not None:
        o = plan.options
        part_or_vertices = prepare_part(plan.vertices, plan.com, o.margin_deg, o.safety_factor,
                                        support=o.support, min_fence_mu=o.min_fence_mu)
    part, file_name = _as_part(part_or_vertices, margin_deg, com)
    name = name or file_name
    data = planning_push_stability(part, n_grid=n_grid)
    deg = np.degrees(data.theta)
    stable = sorted(part.stable, key=lambda e: data.caller_edge(e))
    palette = plt.get_cmap("tab10") if len(stable) <= 10 else plt.get_cmap("tab20")
    color = {e: palette(i % palette.N) for i, e in enumerate(stable)}

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(11, 6.8), sharex=True,
                                 gridspec_kw=dict(height_ratios=[2.2, 0.45 + 0.45 * len(stable)],
                                                  hspace=0.08))
    step = 360.0 / len(deg)
    for a, b, e in _runs(data.final_edge):
        fc = color.get(e, "0.6")
        ax.axvspan(deg[a] - 0.5 * step, deg[b - 1] + 0.5 * step, color=fc, alpha=0.22, lw=0)
        bx.axvspan(deg[a] - 0.5 * step, deg[b - 1] + 0.5 * step, color=fc, alpha=0.10, lw=0)
    for a, b, via in _runs(data.via_marginal.astype(int)):
        if via:
            ax.axvspan(deg[a] - 0.5 * step, deg[b - 1] + 0.5 * step, facecolor="none",
                       edgecolor="0.35", hatch="//", lw=0, zorder=1)
    ax.plot(deg, data.radius * 1000.0, color="k", lw=1.3)
    rmin, rmax = float(data.radius.min()) * 1000, float(data.radius.max()) * 1000
    span = rmax - rmin
    ax.set_ylim(rmin - 0.08 * span, rmax + 0.22 * span)
    label_y = rmax + 0.12 * span
    for e in range(part.n):
        x = float(np.degrees(data.edge_theta[e]))
        pair = list(data.caller_edge(e))
        xs = _at_both_ends(x)
        ha = "left" if x < 6 else ("right" if x > 354 else "center")
        if e in color:
            for a_ in (ax, bx):
                for xx in xs:
                    a_.axvline(xx, color=color[e], lw=4.2, zorder=3)
                    a_.axvline(xx, color="white", lw=1.4, zorder=3.1)
            ax.text(x + (1.5 if ha == "left" else -1.5 if ha == "right" else 0), label_y, f"{pair}",
                    ha=ha, va="center", fontsize=9, color=color[e], fontweight="bold",
                    bbox=dict(facecolor="white", edgecolor="none", pad=0.5), zorder=4)
        else:
            for xx in xs:
                ax.axvline(xx, color="0.35", lw=1.0, ls=":", zorder=2)
            ax.text(x, rmin - 0.04 * span, f"{pair}", ha=ha, va="center", fontsize=7,
                    color="0.3", bbox=dict(facecolor="white", edgecolor="none", pad=0.3))
    for x, k in data.divergent:
        for a_ in (ax, bx):
            for xx in _at_both_ends(math.degrees(x)):
                a_.axvline(xx, color="k", lw=2.2, zorder=3)
        ax.text(math.degrees(x), rmax + 0.04 * span, f"v{part.polygon.hull_index[k]}", ha="left",
                va="bottom", fontsize=7, color="k")
    for x, e, k in data.marginal:
        xd = math.degrees(x)
        r = float(np.max(-(math.sin(x) * part.body[:, 0] + math.cos(x) * part.body[:, 1]))) * 1000.0
        for xx in _at_both_ends(xd):
            ax.plot([xx], [r], marker="X", ms=9, color="tab:red", mec="white", mew=0.8, zorder=6,
                    clip_on=False)
        ax.text(xd + (1.5 if xd < 6 else -1.5 if xd > 354 else 0.0), r + 0.05 * span,
                f"v{part.polygon.hull_index[k]} on {list(data.caller_edge(e))}",
                ha="left" if xd < 6 else ("right" if xd > 354 else "center"), va="bottom",
                fontsize=7, color="tab:red", zorder=6)
    ax.set_ylabel("centre of mass to fence [mm]")
    ax.set_xlim(0, 360)

    # reorient brackets
    nrow = len(stable)
    for r, e in enumerate(stable):
        y = nrow - 1 - r
        x = float(np.degrees(data.edge_theta[e]))
        mx_cw, mx_ccw = np.degrees(part.max_reorient[e])
        st_cw, st_ccw = np.degrees(part.step[e])
        col = color[e]
        _span(bx, x, x + mx_cw, y + 0.14, col, 5.0, 0.13, alpha=0.45)
        _span(bx, x - mx_ccw, x, y + 0.14, col, 5.0, 0.13, alpha=0.45)
        _span(bx, x, x + st_cw, y - 0.14, col, 2.0, 0.09)
        _span(bx, x - st_ccw, x, y - 0.14, col, 2.0, 0.09)
        # labels centred on their brackets: CW above, CCW below
        bx.text(_wrap_deg(x + 0.5 * mx_cw), y + 0.36, f"CW {mx_cw:.1f}° (step {st_cw:.1f}°)",
                fontsize=7, ha="center", va="center", color=col, zorder=5,
                bbox=dict(facecolor="white", edgecolor="none", alpha=0.8, pad=0.2))
        bx.text(_wrap_deg(x - 0.5 * mx_ccw), y - 0.36, f"CCW {mx_ccw:.1f}° (step {st_ccw:.1f}°)",
                fontsize=7, ha="center", va="center", color=col, zorder=5,
                bbox=dict(facecolor="white", edgecolor="none", alpha=0.8, pad=0.2))
    if plan is not None:
        mark_steps(bx, plan, part, data, stable)
    bx.set_ylim(-0.6, nrow - 0.4)
    bx.set_yticks(range(nrow))
    bx.set_yticklabels([f"edge {list(data.caller_edge(e))}" for e in reversed(stable)], fontsize=8)
    bx.set_xlabel("orientation of the part relative to the fence [deg] "
                  "(fence along x below the part, pushing +y; CW turns go left)")
    bx.set_xticks(np.arange(0, 361, 30))

    handles = [Patch(facecolor=color[e], alpha=0.35, label=f"ends on edge {list(data.caller_edge(e))}")
               for e in stable]
    if np.any(data.final_edge < 0):
        handles.append(Patch(facecolor="0.6", alpha=0.35, label="ends on a vertex"))
    if data.marginal:
        pairs = ", ".join(str(list(data.caller_edge(e))) for _, e, _ in data.marginal)
        handles.append(Line2D([], [], ls="none", marker="X", ms=8, color="tab:red",
                              label=f"unstable equilibrium (marginal edge {pairs})"))
    if data.via_marginal.any():
        handles.append(Patch(facecolor="none", edgecolor="0.35", hatch="//",
                             label="rolls over the marginal edge (a centre\nof mass a hair inside "
                                   "it would stop there)"))
    if plan is not None:
        handles.append(Line2D([], [], color="k", lw=1.2, marker=">", markersize=5,
                              label=f"the plan's reorient steps ({plan.n_reorients})"))
    handles += [Line2D([], [], color="0.5", lw=4.2, label="convergent (stable edge)"),
                Line2D([], [], color="k", lw=2.2, label="divergent (vertex)"),
                Line2D([], [], color="0.35", lw=1.0, ls=":", label="unstable edge flush"),
                Line2D([], [], color="0.5", lw=5, alpha=0.45, label="max reorient angle"),
                Line2D([], [], color="0.5", lw=2,
                       label=f"step angle (margin {math.degrees(part.margin):.3g}°)")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    if title is None:
        title = (f"Push stability diagram, normal pushes{': ' + name if name else ''} "
                 f"({part.class_name}, {len(stable)} stable edge{'s' if len(stable) != 1 else ''})")
    ax.set_title(title, fontsize=11)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return data


def _wrap_deg(x: float) -> float:
    return x % 360.0


def _at_both_ends(x: float, tol: float = 1.0) -> list:
    """``x`` (deg), repeated at the other end of the 0..360 axis when it sits on one."""
    if x < tol:
        return [x, x + 360.0]
    if x > 360.0 - tol:
        return [x, x - 360.0]
    return [x]


def plot_funnel(plan: SensorlessPlan, path, name: Optional[str] = None, dpi: int = 150) -> None:
    """Draw the push function of a sensorless plan's part with its funnel and
    save it to ``path``.

    Horizontal axis: the heading relative to the push (degrees, the
    convention of :mod:`planning.pushing.stability`: fence along x below the
    part, moving in +y); vertical axis: the heading the push leaves (the step
    function; basin boundaries, the unstable equilibria, as dotted lines).
    For every orient push ``i``, the possible relative headings before it
    (the whole circle for the first push from any heading, else points) are
    marked on the step they fall on, in push ``i``'s colour.
    """
    f = plan.funnel
    pf = f.push_function
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    th = np.linspace(0.0, 2 * math.pi, 3601)
    out = np.degrees(pf.edge_theta[pf(th)])
    cut = np.abs(np.diff(out)) > 1e-6
    out[1:][cut] = np.nan
    ax.plot(np.degrees(th), out, color="k", lw=1.5, label="push function")
    for d in pf.divergent:
        ax.axvline(math.degrees(d), color="0.6", ls=":", lw=0.8)
    prev = None
    for i, psi in enumerate(f.directions):
        color = PUSH_COLORS[i % len(PUSH_COLORS)]
        if prev is None:
            if plan.start_heading is None:
                ax.axvspan(0, 360, color=color, alpha=0.08, label="push 1: every heading")
                prev = f.states[i]
                continue
            lo, hi = (h - psi + 0.5 * math.pi for h in plan.start_heading)
            rel = np.mod(np.linspace(lo, hi, 200), 2 * math.pi)
            ax.plot(np.degrees(rel), np.degrees(pf.edge_theta[pf(rel)]), ".", ms=2, color=color,
                    label=f"push 1: headings [{math.degrees(plan.start_heading[0]):.4g}, "
                          f"{math.degrees(plan.start_heading[1]):.4g}] deg")
        else:
            turn = psi - f.directions[i - 1]
            rel = np.mod(pf.edge_theta[sorted(prev)] - turn, 2 * math.pi)
            ax.plot(np.degrees(rel), np.degrees(pf.edge_theta[pf(rel)]), "o", ms=7, mfc="none",
                    mew=1.8, color=color, label=f"push {i + 1}: turned {math.degrees(turn):.4g} deg")
        prev = f.states[i]
    title = (f"{name + ': ' if name else ''}push function and funnel ({f.length} orient pushes"
             + (f", period {math.degrees(pf.period):.4g} deg" if pf.symmetry > 1 else "") + ")")
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("heading relative to the push (deg)")
    ax.set_ylabel("heading after the push (deg)")
    ax.set_xlim(0, 360)
    ax.legend(fontsize=7, loc="best")
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    plt.close(fig)

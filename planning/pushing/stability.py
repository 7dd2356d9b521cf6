"""The push stability diagram's data (Akella & Mason Fig. 6, normal pushes):
which stable edge a long normal push ends on, for every orientation of the
part (the push function), computed with the exact replay.

Orientation convention: the fence lies along the world x axis below the part
and moves in +y; ``theta`` is the part's orientation (rad, CCW).

Marginal edges (the foot of the centre of mass at an end of the edge,
:data:`kernels.polygon.MARGINAL_FOOT`) are not stable: the replay of a push
that lands one stops with the part balanced on that end, the centre of mass
straight above it, an unstable equilibrium.  The push function resolves it as
an arbitrarily small perturbation does: turned by any angle off the
equilibrium towards the end vertex's normal cone, the part rolls over that
vertex, and turned the other way it rolls back onto the edge; so every push
that reaches the equilibrium is given the end of a push from inside that cone
(the same for every start in it: no other equilibrium lies there), and only
the equilibrium orientation itself, a single point, is undecided.  A centre of
mass a hair inside such an edge (a stable edge by a hair) would stop those
pushes on it instead: :attr:`PushStability.via_marginal` marks them.
"""
from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from kernels import float64, MARGINAL_FOOT, replay_push
from planning.pushing.options import DEFAULTS
from planning.pushing.part import PushPart, prepare_part


@dataclasses.dataclass(frozen=True)
class PushStability:
    """Data of the push stability diagram for normal pushes.

    Orientation convention: the fence lies along the world x axis below the
    part and moves in +y; ``theta`` is the part's orientation (body frame
    rotated by ``theta``, rad, CCW).  Hull edge ``e`` is flush with the fence
    at ``theta = -pi/2 - nu[e]``.  A CW reorient (``theta`` decreasing) lands
    edge ``e`` from ``theta_e + alpha``, a CCW one from ``theta_e - alpha``.

    Attributes:
      part: the prepared part.
      theta: (N,) grid of orientations in [0, 2 pi), rad.
      final_edge: (N,) hull index of the stable edge a long push ends on, -1
        where it does not end on one (only at divergent orientations, isolated
        points); pushes that reach a marginal edge's equilibrium are resolved
        (module docstring).
      via_marginal: (N,) bool, the push reached a marginal edge's unstable
        equilibrium and ``final_edge`` is its resolution.
      radius: (N,) distance from the centre of mass to the fence, m.
      edge_theta: (n,) orientation at which each hull edge lies flush, rad in [0, 2 pi).
      divergent: orientations (rad in [0, 2 pi)) with the centre of mass straight
        above the touching vertex strictly inside its normal cone (the radius
        function's maxima), and that vertex's hull index.
      marginal: the unstable equilibria of marginal edges: ``(theta, edge,
        vertex)``, the orientation (rad in [0, 2 pi)) at which marginal hull
        ``edge`` lies flush with the centre of mass straight above its end,
        hull ``vertex``.
    """

    part: PushPart
    theta: np.ndarray
    final_edge: np.ndarray
    radius: np.ndarray
    edge_theta: np.ndarray
    divergent: tuple[tuple[float, int], ...]
    via_marginal: np.ndarray
    marginal: tuple[tuple[float, int, int], ...] = ()

    def caller_edge(self, e: int) -> tuple[int, int]:
        """Caller vertex-index pair of hull edge ``e``."""
        return self.part.polygon.edge_vertices(int(e))


@jax.jit
def _final_edges(geom, thetas, distance):
    """Final stable edge and marginal equilibrium (hull indices, -1 none) of a
    normal push of ``distance`` m from each orientation ``thetas`` (rad)."""
    def one(th):
        pose = jnp.stack([jnp.zeros_like(th), jnp.zeros_like(th), th])
        out = replay_push(geom, pose, jnp.array([0.0, 1.0], dtype=thetas.dtype), distance)
        return out.edge, out.marginal
    return jax.vmap(one)(thetas)


def _long_push(body: np.ndarray, radius: float) -> float:
    """A push distance (m) that completes every rotation from any start the
    float64 replay can tell from an equilibrium: each of at most ``n`` passes
    needs ``k ln(tan(beta2/2) / tan(beta1/2))``, below ``1500 k`` for angles
    above 1e-300 rad and below pi by as much (``k`` Peshkin's gain, largest
    over the vertices)."""
    rho = np.hypot(body[:, 0], body[:, 1])
    return 1500.0 * len(body) * float(np.max((radius * radius + rho * rho) / rho))


def _roll_off(part: PushPart, edge_theta: np.ndarray):
    """Per hull edge: the end vertex nearer the centre of mass's foot and an
    orientation (rad) inside that vertex's normal cone, half its width away
    from the edge lying flush: where a part balanced on that vertex with the
    edge flush goes when perturbed off the edge (the CCW turn is the roll-off
    over the edge's start vertex, the CW turn over its end vertex)."""
    foot, ext = np.asarray(part.geom.foot), np.asarray(part.geom.exterior)
    edges = np.arange(part.n)
    at_start = foot < 0.5
    vertex = np.where(at_start, edges, (edges + 1) % part.n)
    return vertex, edge_theta + np.where(at_start, 0.5, -0.5) * ext[vertex]


@float64
def push_stability(part_or_vertices, margin_deg: float = DEFAULTS.margin_deg, com=None,
                   n_grid: int = 3600) -> PushStability:
    """Compute the push stability data of a polygonal part for normal pushes.

    Every orientation of an ``n_grid`` grid is pushed by a long normal push
    (longer than every Peshkin distance away from the equilibria themselves,
    :func:`_long_push`) with the exact replay :func:`kernels.push.replay_push`,
    vmapped; pushes that end at a marginal edge's unstable equilibrium are
    resolved as the module docstring says.

    Args:
      part_or_vertices: a :class:`~planning.pushing.part.PushPart` or an
        (m, 2) vertex array (metres).
      margin_deg: margin angle (degrees) for the step angles (ignored for a PushPart).
      com: centre of mass (m), default the file's or the area centroid.
      n_grid: number of orientations.
    """
    part = part_or_vertices if isinstance(part_or_vertices, PushPart) else \
        prepare_part(np.asarray(part_or_vertices, dtype=float), com, margin_deg)
    return _stability(part, n_grid)


def _stability(part: PushPart, n_grid: int) -> PushStability:
    geom, body = part.geom, part.body
    theta = np.arange(n_grid) * (2 * math.pi / n_grid)
    edge_theta = np.mod(-0.5 * math.pi - part.nu, 2 * math.pi)
    pivot, roll_theta = _roll_off(part, edge_theta)
    # one replay call: the grid, then one roll-off start per edge (used for the marginal ones)
    edges, marg = (np.asarray(a) for a in _final_edges(
        geom, jnp.asarray(np.concatenate([theta, roll_theta])),
        jnp.asarray(_long_push(body, float(geom.radius)))))
    final, via = _resolve(edges[:n_grid], marg[:n_grid], edges[n_grid:], marg[n_grid:])
    # distance from the centre of mass to the fence: support of the part in direction -y
    c, s = np.cos(theta), np.sin(theta)
    rad = np.max(-(s[:, None] * body[None, :, 0] + c[:, None] * body[None, :, 1]), axis=1)
    foot, marginal_edge = np.asarray(geom.foot), np.asarray(geom.marginal)
    tol = MARGINAL_FOOT
    div = []
    for k, v in enumerate(body):
        # the direction of vertex k strictly inside its normal cone: the feet on its two
        # edges (k-1 -> k, k -> k+1) lie strictly before and after it
        if foot[k] > tol and foot[k - 1] < 1.0 - tol:
            div.append((float(np.mod(-0.5 * math.pi - math.atan2(v[1], v[0]), 2 * math.pi)), k))
    marginal = tuple((float(edge_theta[e]), int(e), int(pivot[e])) for e in np.flatnonzero(marginal_edge))
    return PushStability(part=part, theta=theta, final_edge=final, radius=rad,
                         edge_theta=edge_theta, divergent=tuple(sorted(div)), via_marginal=via,
                         marginal=tuple(sorted(marginal)))


def _resolve(edges, marg, roll_edges, roll_marg):
    """Final edges of the grid with each marginal equilibrium replaced by where
    its roll-off push ends (following roll-offs onto further marginal edges);
    returns ``(final_edge, via_marginal)``.  ``edges``/``marg``: the grid's
    replay; ``roll_edges``/``roll_marg``: the replay from each edge's roll-off start."""
    n = len(roll_edges)
    resolved = np.full(n, -1)
    for e in range(n):
        cur = e
        for _ in range(n):
            if roll_marg[cur] < 0:
                resolved[e] = roll_edges[cur]
                break
            cur = int(roll_marg[cur])
    via = marg >= 0
    return np.where(via, resolved[np.maximum(marg, 0)], edges), via

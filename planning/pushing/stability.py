"""The push stability diagram's data (Akella & Mason Fig. 6, normal pushes):
which stable edge a long normal push ends on, for every orientation of the
part, computed with the exact replay.

Orientation convention: the fence lies along the world x axis below the part
and moves in +y; ``theta`` is the part's orientation (rad, CCW).
"""
from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from kernels.precision import float64
from kernels.push import replay_push
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
        where it does not end on one (only at divergent orientations).
      radius: (N,) distance from the centre of mass to the fence, m.
      edge_theta: (n,) orientation at which each hull edge lies flush, rad in [0, 2 pi).
      divergent: orientations (rad in [0, 2 pi)) with the centre of mass straight
        above the touching vertex, and that vertex's hull index.
    """

    part: PushPart
    theta: np.ndarray
    final_edge: np.ndarray
    radius: np.ndarray
    edge_theta: np.ndarray
    divergent: tuple[tuple[float, int], ...]

    def caller_edge(self, e: int) -> tuple[int, int]:
        """Caller vertex-index pair of hull edge ``e``."""
        return self.part.polygon.edge_vertices(int(e))


@jax.jit
def _final_edges(geom, thetas, distance):
    def one(th):
        pose = jnp.stack([jnp.zeros_like(th), jnp.zeros_like(th), th])
        return replay_push(geom, pose, jnp.array([0.0, 1.0], dtype=thetas.dtype), distance).edge
    return jax.vmap(one)(thetas)


@float64
def push_stability(part_or_vertices, margin_deg: float = 7.0, com=None,
                   n_grid: int = 3600) -> PushStability:
    """Compute the push stability data of a polygonal part for normal pushes.

    Every orientation of an ``n_grid`` grid is pushed by a long normal push
    (1000 part radii, far beyond every Peshkin distance away from the
    divergent orientations themselves) with the exact replay
    :func:`kernels.push.replay_push`, vmapped.

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
    geom = part.geom
    theta = np.arange(n_grid) * (2 * math.pi / n_grid)
    radius_len = float(geom.radius)
    final = np.asarray(_final_edges(geom, jnp.asarray(theta), jnp.asarray(1000.0 * radius_len)))
    body = part.body
    # distance from the centre of mass to the fence: support of the part in direction -y
    c, s = np.cos(theta), np.sin(theta)
    rad = np.max(-(s[:, None] * body[None, :, 0] + c[:, None] * body[None, :, 1]), axis=1)
    edge_theta = np.mod(-0.5 * math.pi - part.nu, 2 * math.pi)
    div = []
    for k, v in enumerate(body):
        if np.all(body @ v <= v @ v * (1 + 1e-12)):  # vertex k is the support point along v_k
            div.append((float(np.mod(-0.5 * math.pi - math.atan2(v[1], v[0]), 2 * math.pi)), k))
    return PushStability(part=part, theta=theta, final_edge=final, radius=rad,
                         edge_theta=edge_theta, divergent=tuple(sorted(div)))

"""Planar rigid motions of tumble words, in numpy (host side, float64).

A proper planar rigid motion ``q -> e^{i a} q + z`` is a :class:`Motion`
``(a, z)`` with ``a`` in radians (NOT wrapped: angles of long words add up,
which keeps "exactly a multiple of 2 pi" visible) and ``z`` a complex number
(metres, ``x + i y``).  It is the same object as
:class:`kernels.tumble.RigidMotion2D`, written here in numpy so that the planner
can compose thousands of words per goal without JAX dispatch.

Conventions (those of :mod:`kernels.tumble`): the **effect** of a word ``w``
from face ``F`` is the pose, in ``F``'s frame at the start, of the frame of the
face that is on the plane after ``w``.  Effects compose frame-relatively:
``effect(w1 w2) = compose(effect(w1), effect(w2))`` with
``compose(m1, m2) = (a1 + a2, z1 + e^{i a1} z2)``.  From a world pose ``P``
(face frame -> world) the word ends at ``P o effect(w)``.

:class:`TumbleTable` holds, for every ordered pair of adjacent faces
``(f, g)``, the pose of ``g``'s frame in ``f``'s frame after the tumble
``f -> g``.  It is computed with the same formula as the kernel's step (edge
midpoint matched, edge direction aligned) from the kernel's own
``TumbleGeometry.corners_2d``, and the tests check word effects against
:func:`kernels.tumble.replay`.
"""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np


TWO_PI = 2.0 * math.pi

__all__ = [
    "Motion",
    "IDENTITY",
    "compose",
    "inverse_motion",
    "power_motion",
    "rotation_about",
    "fixed_point",
    "TumbleTable",
]


@dataclass(frozen=True)
class Motion:
    """``q -> e^{i angle} q + z`` (angle rad, unwrapped; z complex metres)."""

    angle: float
    z: complex

    @property
    def xy(self) -> tuple[float, float]:
        return (self.z.real, self.z.imag)


IDENTITY = Motion(0.0, 0j)


def compose(m1: Motion, m2: Motion) -> Motion:
    """``m1 o m2``: the effect of word ``w1`` followed by word ``w2``."""
    return Motion(m1.angle + m2.angle, m1.z + cmath.exp(1j * m1.angle) * m2.z)


def inverse_motion(m: Motion) -> Motion:
    """The effect of the reversed word."""
    return Motion(-m.angle, -cmath.exp(-1j * m.angle) * m.z)


def power_motion(m: Motion, n: int) -> Motion:
    """``m^n`` for any integer ``n`` (repeated squaring, O(log |n|) compositions)."""
    n = int(n)
    if n < 0:
        m, n = inverse_motion(m), -n
    out = IDENTITY
    base = m
    while n:
        if n & 1:
            out = compose(out, base)
        base = compose(base, base)
        n >>= 1
    return out


def rotation_about(centre: complex, angle: float) -> Motion:
    """Rotation by ``angle`` about ``centre``: ``q -> c + e^{ia}(q - c)``."""
    e = cmath.exp(1j * angle)
    return Motion(angle, centre - e * centre)


def fixed_point(m: Motion) -> complex | None:
    """The point ``c`` with ``m(c) = c``; ``None`` for a (numerically) pure
    translation (``|sin(a/2)| < 1e-12``)."""
    s = math.sin(0.5 * m.angle)
    if abs(s) < 1e-12:
        return None
    return m.z / (1.0 - cmath.exp(1j * m.angle))


class TumbleTable:
    """Relative motion of every elementary tumble of a part (numpy).

    Attributes:
      n_faces: number of faces ``F``.
      nf: (F, K) int, face across edge slot k of face f (-1 pad) -- the
        kernel's ``next_face``.
      step_angle: (F, K) float, angle of the landing face's frame in ``f``'s
        frame after tumbling across slot k.
      step_z: (F, K) complex, its origin.
      neighbors: per face, the tuple of adjacent faces (slot order).
    """

    def __init__(self, corners_2d: np.ndarray, next_face: np.ndarray, next_slot: np.ndarray,
                 face_sizes: Sequence[int]):
        C = np.asarray(corners_2d, dtype=float)
        nf = np.asarray(next_face, dtype=np.int64)
        ns = np.asarray(next_slot, dtype=np.int64)
        F, K = nf.shape
        sizes = np.asarray(face_sizes, dtype=np.int64)
        ang = np.zeros((F, K))
        zz = np.zeros((F, K), dtype=complex)
        for f in range(F):
            s = int(sizes[f])
            for k in range(s):
                g = int(nf[f, k])
                ca, cb = C[f, k], C[f, (k + 1) % s]
                sg = int(sizes[g])
                qb, qa = C[g, ns[f, k]], C[g, (ns[f, k] + 1) % sg]
                dp, dq = cb - ca, qb - qa
                cr = dq[0] * dp[1] - dq[1] * dp[0]
                dt = dq[0] * dp[0] + dq[1] * dp[1]
                phi = math.atan2(cr, dt)
                c, sn = math.cos(phi), math.sin(phi)
                mq = 0.5 * (qa + qb)
                mp = 0.5 * (ca + cb)
                xy = mp - np.array([c * mq[0] - sn * mq[1], sn * mq[0] + c * mq[1]])
                ang[f, k] = phi
                zz[f, k] = complex(xy[0], xy[1])
        self.n_faces = F
        self.nf = nf
        self.step_angle = ang
        self.step_z = zz
        self.neighbors = tuple(tuple(int(g) for g in nf[f, : int(sizes[f])]) for f in range(F))
        self._slot = {(f, g): k for f in range(F) for k, g in enumerate(self.neighbors[f])}

    @classmethod
    def from_polyhedron(cls, P, geom=None) -> "TumbleTable":
        """Table of a :class:`kernels.polyhedron.Polyhedron` (``geom``: its
        float64 ``TumbleGeometry``; default ``P.geometry()``)."""
        if geom is None:
            geom = P.geometry()
        topo = P.topology
        return cls(np.asarray(geom.corners_2d), topo.next_face_array, topo.next_slot_array,
                   [len(c) for c in topo.face_cycles])

    def adjacency(self) -> dict[int, tuple[int, ...]]:
        return {f: self.neighbors[f] for f in range(self.n_faces)}

    def step(self, f: int, g: int) -> Motion:
        k = self._slot.get((f, g))
        if k is None:
            raise ValueError(f"faces {f} and {g} are not adjacent")
        return Motion(float(self.step_angle[f, k]), complex(self.step_z[f, k]))

    def word_motion(self, start_face: int, word: Sequence[int]) -> Motion:
        """Effect of ``word`` (landing faces) from ``start_face``."""
        a = 0.0
        z = 0j
        f = int(start_face)
        for g in word:
            g = int(g)
            k = self._slot.get((f, g))
            if k is None:
                raise ValueError(f"word: face {g} is not adjacent to face {f}")
            z += cmath.exp(1j * a) * complex(self.step_z[f, k])
            a += float(self.step_angle[f, k])
            f = g
        return Motion(a, z)

"""Plan types of the tumbling planner (Marigo-Bicchi): frozen dataclasses that
serialise to JSON-ready dicts and back.

Frames and units (``DESIGN.md``): metres, radians (CCW positive, wrapped to
(-pi, pi]).  A configuration ``(x, y, theta, face)``: ``face`` (a face number of
:func:`kernels.polyhedron.make_polyhedron` -- faces are numbered in
lexicographic order of their sorted corner-index tuples) lies on the plane and
its face frame sits at world ``(x, y)`` with its x-axis at angle ``theta``.
Edges are pairs of indices into the caller's own vertex list, so anyone with
the part can check a plan with :func:`kernels.tumble.replay`.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from typing import ClassVar, Optional

import numpy as np

from kernels import PartWarning, angle_distance, make_polyhedron

VERDICTS = ("solved", "not_solvable", "budget_exhausted")
REACHABLE_CLASSES = ("discrete", "dense", "dense_lines")
BOUND_KEYS = ("Delta_D", "Delta_beta", "Delta_gen", "E", "U_max", "Delta_theta_f", "Delta_C_f",
              "tumbles_L_f", "tumbles_R_bar_k", "tumbles_translation", "lattice_mesh_Delta", "beta")

__all__ = ["Tumble", "TumblePlan", "config_error", "reaches", "VERDICTS", "REACHABLE_CLASSES",
           "BOUND_KEYS"]


@functools.lru_cache(maxsize=64)
def _nominal_polyhedron(vertices: tuple, com: tuple, tau_v):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        return make_polyhedron(np.asarray(vertices), np.asarray(com), tau_v=tau_v)


def config_error(c1, c2) -> float:
    """The paper's distance between configurations ``(x, y, theta, face)``:
    ``max(|dxy|, |dtheta| wrapped, 1 - delta(face1, face2))`` (metres and
    radians; 1 for a wrong face).  Use :func:`reaches` to decide success: with
    ``eps >= 1`` this distance alone would accept a wrong face."""
    dxy = math.hypot(float(c1[0]) - float(c2[0]), float(c1[1]) - float(c2[1]))
    dth = angle_distance(c1[2], c2[2])
    df = 0.0 if int(c1[3]) == int(c2[3]) else 1.0
    return max(dxy, dth, df)


def reaches(final, goal, eps: float) -> bool:
    """Whether configuration ``final`` solves ``goal`` to accuracy ``eps``:
    the same face, and ``config_error(final, goal) <= eps``."""
    return int(final[3]) == int(goal[3]) and config_error(final, goal) <= eps


def _config(x, name: str) -> tuple[float, float, float, int]:
    t = tuple(x)
    if len(t) != 4:
        raise ValueError(f"{name}: expected (x, y, theta, face), got {len(t)} entries")
    return (float(t[0]), float(t[1]), float(t[2]), int(t[3]))


def _num(x) -> Optional[float]:
    return None if x is None else float(x)


@dataclasses.dataclass(frozen=True)
class Tumble:
    """One elementary tumble.

    Attributes:
      edge: the edge turned about, ``(a, b)`` caller vertex indices, ``a < b``
        (shared by the face on the plane before and ``face``).
      face: the face number that lands.
    """

    edge: tuple[int, int]
    face: int

    def to_dict(self) -> dict:
        return {"edge": [int(self.edge[0]), int(self.edge[1])], "face": int(self.face)}

    @classmethod
    def from_dict(cls, d) -> "Tumble":
        e = d["edge"]
        if len(e) != 2:
            raise ValueError(f"edge: expected a vertex-index pair, got {e!r}")
        return cls(edge=(int(e[0]), int(e[1])), face=int(d["face"]))


@dataclasses.dataclass(frozen=True)
class TumblePlan:
    """A tumble plan with its verification and the paper's analysis.

    Attributes:
      vertices, com: the part (caller's body frame, metres).
      start, goal: configurations ``(x, y, theta, face)``.
      eps: required accuracy (paper's metric).
      tau_v: vertex tolerance (m); tau_g: generator-coefficient tolerance
        (None = exact for a discrete reachable set, else the default).
      tumbles: the tumbles in execution order.
      predicted_final: the configuration reached by replaying ``tumbles`` from
        ``start`` with :func:`kernels.tumble.replay` (float64).
      error: ``config_error(predicted_final, goal)``.
      bounds: the paper's analytic bounds (floats, ``inf`` when they
        overflow): Delta_D, Delta_beta, Delta_gen, E, U_max (eq. 4),
        Delta_theta_f (eq. 5), Delta_C_f (eq. 6), tumbles_L_f, tumbles_R_bar_k,
        tumbles_translation (Sec. IV), lattice_mesh_Delta, beta; and a few
        extra planner numbers (orientation_residual, position_residual ...).
      verdict: ``"solved"`` (the plan ends on the goal face within eps),
        ``"not_solvable"`` or ``"budget_exhausted"`` (the effort budget ran out
        first; the plan is the best one found); see
        :mod:`planning.tumbling.verdict`.
      reason: a human-readable explanation.
      reachable_class: ``"discrete"``, ``"dense"`` or ``"dense_lines"``, at
        the part's tolerance ``tau_v`` (the class the planner used).
      n_tumbles_paper: tumble count of the paper's construction (steps 1-5,
        purged) for this goal (a Python int; it can exceed 2**63).
      reachable_class_exact: the class of the coordinates as given
        (rationality decided at 1e-12; None in plans made before it existed).
      step5_ok: with ``tau_v > 0``, whether the paper's step-5 checks (eqs. 5,
        6: worst case over every part within tau_v) hold; None for tau_v = 0.
      effort_used: operations the planner spent (see
        :mod:`planning.tumbling.effort`).

    The plan interface (:mod:`planning.kinds`): ``kind`` ``"tumble"``,
    :attr:`n_steps`, ``verdict`` (a field), :meth:`nominal_part`, :meth:`draw_shape`.
    """

    #: the plan's kind: its key in the evaluation's dispatch table (:mod:`planning.kinds`)
    kind: ClassVar[str] = "tumble"

    vertices: tuple[tuple[float, float, float], ...]
    com: tuple[float, float, float]
    start: tuple[float, float, float, int]
    goal: tuple[float, float, float, int]
    eps: float
    tau_v: float
    tau_g: Optional[float]
    tumbles: tuple[Tumble, ...]
    predicted_final: tuple[float, float, float, int]
    error: float
    bounds: dict
    verdict: str
    reason: str
    reachable_class: str
    n_tumbles_paper: int
    reachable_class_exact: Optional[str] = None
    step5_ok: Optional[bool] = None
    effort_used: int = 0

    @property
    def n_tumbles(self) -> int:
        return len(self.tumbles)

    @property
    def n_steps(self) -> int:
        """The plan's steps (its tumbles): the plan interface."""
        return len(self.tumbles)

    def nominal_part(self):
        """The nominal part, a :class:`kernels.Polyhedron` with its faces as the
        planner merged them at the plan's ``tau_v``; built once per part (a Qhull
        call and the face merging cost a few ms)."""
        return _nominal_polyhedron(tuple(map(tuple, np.asarray(self.vertices, np.float64).tolist())),
                                   tuple(np.asarray(self.com, np.float64).tolist()), self.tau_v)

    def draw_shape(self) -> dict:
        """What a sampler draws for one sample of this plan: the keywords
        ``n_vertices``, ``dim`` (3), ``n_tumbles`` of
        :meth:`robustness.Sampler.sample` and of its columns."""
        return dict(n_vertices=len(self.vertices), dim=3, n_tumbles=self.n_tumbles)

    @property
    def faces(self) -> tuple[int, ...]:
        """The landing faces in order (the word replayed by the kernel)."""
        return tuple(t.face for t in self.tumbles)

    def to_dict(self) -> dict:
        """JSON-ready dict (round-trips through :meth:`from_dict`)."""
        return {
            "vertices": [list(v) for v in self.vertices],
            "com": list(self.com),
            "start": list(self.start),
            "goal": list(self.goal),
            "eps": self.eps,
            "tau_v": self.tau_v,
            "tau_g": self.tau_g,
            "tumbles": [t.to_dict() for t in self.tumbles],
            "predicted_final": list(self.predicted_final),
            "error": self.error,
            "bounds": dict(self.bounds),
            "verdict": self.verdict,
            "reason": self.reason,
            "reachable_class": self.reachable_class,
            "n_tumbles_paper": int(self.n_tumbles_paper),
            "reachable_class_exact": self.reachable_class_exact,
            "step5_ok": self.step5_ok,
            "effort_used": int(self.effort_used),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "TumblePlan":
        """Inverse of :meth:`to_dict`."""
        if d["verdict"] not in VERDICTS:
            raise ValueError(f"verdict: expected one of {VERDICTS}, got {d['verdict']!r}")
        for k in ("reachable_class", "reachable_class_exact"):
            if d.get(k) is not None and d[k] not in REACHABLE_CLASSES:
                raise ValueError(f"{k}: expected one of {REACHABLE_CLASSES}, got {d[k]!r}")
        step5 = d.get("step5_ok")
        return cls(
            vertices=tuple(tuple(float(c) for c in v) for v in d["vertices"]),
            com=tuple(float(c) for c in d["com"]),
            start=_config(d["start"], "start"),
            goal=_config(d["goal"], "goal"),
            eps=float(d["eps"]),
            tau_v=float(d["tau_v"]),
            tau_g=_num(d.get("tau_g")),
            tumbles=tuple(Tumble.from_dict(t) for t in d["tumbles"]),
            predicted_final=_config(d["predicted_final"], "predicted_final"),
            error=float(d["error"]),
            bounds={str(k): (None if v is None else float(v)) for k, v in d["bounds"].items()},
            verdict=str(d["verdict"]),
            reason=str(d["reason"]),
            reachable_class=str(d["reachable_class"]),
            n_tumbles_paper=int(d["n_tumbles_paper"]),
            reachable_class_exact=(None if d.get("reachable_class_exact") is None
                                   else str(d["reachable_class_exact"])),
            step5_ok=None if step5 is None else bool(step5),
            effort_used=int(d.get("effort_used", 0)),
        )

    def summary(self) -> str:
        """A short human-readable description of the plan."""
        s, g, p = self.start, self.goal, self.predicted_final
        npaper = self.n_tumbles_paper
        np_txt = f"{npaper}" if npaper < 10**12 else f"~{float(npaper):.3e}"
        cls = f"{self.reachable_class} reachable set"
        if self.reachable_class_exact not in (None, self.reachable_class):
            cls += f" at tau_v = {self.tau_v:g} m, {self.reachable_class_exact} exactly"
        lines = [
            f"tumble plan: {self.verdict} ({cls}), "
            f"{self.n_tumbles} tumbles (paper's construction: {np_txt}); "
            f"error {self.error:.3e} (eps {self.eps:g})",
            f"  start  ({s[0]:.6g}, {s[1]:.6g}, {s[2]:.6g}, face {s[3]})",
            f"  goal   ({g[0]:.6g}, {g[1]:.6g}, {g[2]:.6g}, face {g[3]})",
            f"  final  ({p[0]:.6g}, {p[1]:.6g}, {p[2]:.6g}, face {p[3]})",
            f"  reason: {self.reason}",
        ]
        if self.tumbles:
            faces = " ".join(str(t.face) for t in self.tumbles[:60])
            more = " ..." if self.n_tumbles > 60 else ""
            lines.append(f"  faces: {faces}{more}")
        return "\n".join(lines)

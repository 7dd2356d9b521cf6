"""Tolerance models: what the supplier makes, the friction of the cell, and
what the robot does (host-side settings, validated on construction).

One definition of each, used by the samplers (:mod:`robustness.samplers`), the
analytic bounds (:mod:`robustness.bounds`) and the config files of the edge
(:mod:`sweeps.config` validates a YAML mapping straight into these types).
Units: metres, radians; a relative distance error is a fraction.  Every
half-width is a box: an offset never leaves it (Gaussians are truncated to it),
so the box bounds of :mod:`robustness.bounds` hold for every draw.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Literal, Optional, Sequence

import numpy as np

from kernels import SUPPORT_FAMILIES
from robustness.stats import CONFIDENCE, REQUIRED_PROBABILITY

DISTRIBUTIONS = ("uniform", "gaussian")
#: support families (``any`` mixes rigid, uniform, ring and tripod; ``points`` is
#: the sampled Dirichlet distribution, model only)
SUPPORTS = SUPPORT_FAMILIES
COM_SHAPES = ("disc", "box")


# --------------------------------------------------------------------------
def check_nonneg(obj, name: str, fix: str = "") -> None:
    """Raise ValueError naming ``name`` unless ``obj.name`` is a finite number >= 0."""
    v = getattr(obj, name)
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v >= 0
    if not ok:
        raise ValueError(f"{name}: must be a finite number >= 0 (a tolerance half-width), got "
                         f"{v!r}{fix}")


def _range(obj, name: str, lo_ok: float = 0.0) -> None:
    v = getattr(obj, name)
    try:
        lo, hi = (float(x) for x in v)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a range [low, high], got {v!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo < lo_ok or hi < lo:
        raise ValueError(f"{name}: expected finite {lo_ok:g} <= low <= high, got [{lo}, {hi}]")
    object.__setattr__(obj, name, (lo, hi))


@dataclasses.dataclass(frozen=True)
class GeometryTolerance:
    """Part tolerances (the supplier).

    Attributes:
      tau_v: half-width of each vertex coordinate's offset, m.
      tau_com: half-width (box) or radius (disc) of the centre-of-mass offset, m.
      distribution: ``"uniform"`` (vertex offsets uniform in the box) or
        ``"gaussian"`` (normal with ``sigma_v``, truncated to the box).
      sigma_v: standard deviation of a Gaussian vertex offset, m (default
        ``tau_v / 2``); ignored for ``uniform``.
      com_shape: ``"disc"`` (uniform in the disc / ball of radius tau_com) or
        ``"box"`` (uniform in the box of half-width tau_com).
    """

    tau_v: float = 0.0
    tau_com: float = 0.0
    distribution: Literal["uniform", "gaussian"] = "uniform"
    sigma_v: Optional[float] = None
    com_shape: Literal["disc", "box"] = "disc"

    def __post_init__(self):
        check_nonneg(self, "tau_v")
        check_nonneg(self, "tau_com")
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"distribution: expected one of {DISTRIBUTIONS}, got {self.distribution!r}")
        if self.com_shape not in COM_SHAPES:
            raise ValueError(f"com_shape: expected one of {COM_SHAPES}, got {self.com_shape!r}")
        if self.sigma_v is not None:
            check_nonneg(self, "sigma_v")

    @property
    def sigma(self) -> float:
        """Gaussian standard deviation actually used, m."""
        return float(self.sigma_v) if self.sigma_v is not None else 0.5 * self.tau_v


@dataclasses.dataclass(frozen=True)
class FrictionRange:
    """Friction ranges (the cell) and the part's support.

    Attributes:
      mu_f: ``(low, high)`` fence-part Coulomb coefficient, uniform.
      mu_s: ``(low, high)`` support coefficient, uniform (recorded only; it
        cancels out of quasi-static kinematics).
      support: the support family (:mod:`kernels.support`): ``"any"`` (the
        default when ``c`` is not given: a mixture, in equal parts, of rigid
        corner support, a uniform pad, a rim and a tripod with ``c`` from a
        tenth of the largest tripod that fits inside the outline to all of
        it: the range of supports a part whose support nobody measured may
        have), ``"rigid"`` (the part rests on three of its corners, which three
        drawn from its flatness errors), ``"uniform"``, ``"ring"``,
        ``"tripod"`` (three feet at the sampled ``c``: needs ``c``; the
        default when ``c`` is given), ``"points"`` (the sampled Dirichlet
        distribution below; the quasi-static model only: its loads cannot be
        realised by feet).
      support_points: number of support points of the ``points`` family's
        pressure distribution (>= 1).
      weight_concentration: integer Dirichlet concentration of their weights
        (1: uniform on the simplex; large: nearly equal weights), 1..64.
      c: optional ``(low, high)`` range (m) of the ``tripod`` family's
        limit-surface ratio, uniform.
    """

    mu_f: tuple[float, float] = (0.5, 0.5)
    mu_s: tuple[float, float] = (0.5, 0.5)
    support_points: int = 16
    weight_concentration: int = 1
    c: Optional[tuple[float, float]] = None
    support: Optional[str] = None

    def __post_init__(self):
        _range(self, "mu_f")
        _range(self, "mu_s")
        if self.c is not None:
            _range(self, "c")
            if self.c[0] <= 0:
                raise ValueError(f"c: the limit-surface ratio must be > 0 m, got {list(self.c)}")
        sp = self.support_points
        if not isinstance(sp, int) or isinstance(sp, bool) or sp < 1:
            raise ValueError(f"support_points: expected an integer >= 1, got {sp!r}")
        wc = self.weight_concentration
        if not (isinstance(wc, int) and not isinstance(wc, bool) and 1 <= wc <= 64):
            raise ValueError(f"weight_concentration: expected an integer in 1..64, got {wc!r}")
        if self.support is None:
            object.__setattr__(self, "support", "tripod" if self.c is not None else "any")
        if self.support not in SUPPORTS:
            raise ValueError(f"support: expected one of {', '.join(SUPPORTS)}, got {self.support!r}")
        if self.support == "tripod" and self.c is None:
            raise ValueError("support: 'tripod' needs its limit-surface ratio range: add c: [lo, hi] (m)")
        if self.c is not None and self.support != "tripod":
            raise ValueError(f"c: a limit-surface ratio range is the tripod family's; drop c or set "
                             f"support: tripod (got support: {self.support})")
        if self.support != "points" and (sp != 16 or wc != 1):
            raise ValueError(f"support_points: support_points and weight_concentration describe the "
                             f"'points' family only; set support: points or drop them (got support: "
                             f"{self.support})")


@dataclasses.dataclass(frozen=True)
class ExecutionTolerance:
    """Robot execution errors (half-widths).

    Attributes:
      start_xy: start position error, each coordinate, m.
      start_theta: start orientation error, rad.
      fence_angle: fence direction error of each push, rad (CCW rotation of
        the push direction).
      distance_abs: absolute push-distance error, m.
      distance_rel: relative push-distance error (fraction of the distance).
      tumble_slip_xy: planar slip after each tumble, each coordinate, m.
      tumble_slip_theta: rotational slip after each tumble, rad.
      distribution: ``"uniform"`` in the boxes or ``"gaussian"`` (sigma = half
        the half-width, truncated to the box).
    """

    start_xy: float = 0.0
    start_theta: float = 0.0
    fence_angle: float = 0.0
    distance_abs: float = 0.0
    distance_rel: float = 0.0
    tumble_slip_xy: float = 0.0
    tumble_slip_theta: float = 0.0
    distribution: Literal["uniform", "gaussian"] = "uniform"

    def __post_init__(self):
        for f in dataclasses.fields(self):
            if f.name != "distribution":
                check_nonneg(self, f.name)
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"distribution: expected one of {DISTRIBUTIONS}, got {self.distribution!r}")


@dataclasses.dataclass(frozen=True)
class SuccessCriterion:
    """When a sample succeeds, and how a failed one failed: the one rule of every
    model's rows (the kinematic push and tumble replays, the MuJoCo rollouts,
    robust synthesis' scores).

    A sample succeeds when it may (``valid``: inside its model, nothing that
    rules it out) and its final pose is within ``pos_eps_m`` (m, Euclidean) and
    ``theta_eps_rad`` (rad, |wrapped difference|) of the goal (:meth:`success`).
    A failed sample gets the first that applies of its named faults (the
    model's, in the model's order: ``hull_changed``, ``wrong_edge``...), then
    ``slip`` (slip at least ``slip_fraction`` x ``pos_eps_m``), ``position``
    (position error above ``pos_eps_m``, or not a number), ``orientation``
    (:meth:`classify`).

    Attributes:
      pos_eps_m: position tolerance (m), finite and > 0.
      theta_eps_rad: orientation tolerance (rad), finite and > 0.
      slip_fraction: a failed sample whose slip reaches this fraction of
        ``pos_eps_m`` fails by ``slip`` (finite, >= 0).

    The defaults are a push plan's; a tumble plan's are its own accuracy
    (:meth:`for_plan`).  A study's or certification's ``eps:`` section validates
    into this value (:class:`sweeps.config.Evaluation`).
    """

    pos_eps_m: float = 1e-3
    theta_eps_rad: float = math.radians(1.0)
    slip_fraction: float = 0.25

    def __post_init__(self):
        for name in ("pos_eps_m", "theta_eps_rad"):
            v = getattr(self, name)
            ok = (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                  and v > 0)
            if not ok:
                raise ValueError(f"{name}: expected a finite number > 0, got {v!r}")
            object.__setattr__(self, name, float(v))
        check_nonneg(self, "slip_fraction", " (a fraction of pos_eps_m)")
        object.__setattr__(self, "slip_fraction", float(self.slip_fraction))

    @classmethod
    def for_plan(cls, plan) -> "SuccessCriterion":
        """The default criterion of a plan's kind: a tumble plan's own accuracy
        ``plan.eps`` (m and rad) for both tolerances; the class defaults (1 mm,
        1 degree) for a push plan: the ``default_eps`` of the plan kind's row of
        the dispatch table (:data:`robustness.kinds.KINDS`)."""
        from robustness.kinds import kind_of   # not at the top: kinds -> bounds -> this module

        eps = kind_of(plan).default_eps(plan)
        return cls() if eps is None else cls(*eps)

    def within(self, err_pos_m, err_theta_rad) -> np.ndarray:
        """Whether final-pose errors (position m, orientation rad, any sign) are
        within the tolerances (NaN: not within)."""
        return ((np.asarray(err_pos_m) <= self.pos_eps_m)
                & (np.abs(np.asarray(err_theta_rad)) <= self.theta_eps_rad))

    def success(self, err_pos_m, err_theta_rad, valid=True) -> np.ndarray:
        """A sample's success: ``valid`` (bool, broadcast) and :meth:`within`."""
        return np.asarray(valid, bool) & self.within(err_pos_m, err_theta_rad)

    def classify(self, err_pos_m, err_theta_rad, slip_m, *, valid=True,
                 faults: Sequence = ()) -> tuple[np.ndarray, np.ndarray]:
        """Success and failure mode of each sample.

        Args:
          err_pos_m: position error to the goal (m), shape (n,).
          err_theta_rad: orientation error to the goal (rad, wrapped), (n,).
          slip_m: the sample's slip (m), (n,).
          valid: whether each sample may succeed (bool, broadcast): its model
            valid and nothing that rules a success out (a wrong final face, a
            part that left the workspace).  Every reason for ``False`` should be
            named in ``faults``.
          faults: the model's named faults, in the order they are assigned:
            ``(mode, (n,) bool)`` pairs (a fault that does not rule a success
            out, such as an intermediate push on another edge, leaves a success
            a success).

        Returns:
          ``(success, failure_mode)``: (n,) bool and (n,) strings, ``"none"`` for
          a success, else the first named fault that applies, ``"slip"``,
          ``"position"`` or ``"orientation"``.
        """
        ep = np.asarray(err_pos_m)
        ok = self.success(ep, err_theta_rad, valid)
        names = [str(m) for m, _ in faults] + ["slip", "position"]
        conds = ([np.asarray(c, bool) for _, c in faults]
                 + [np.asarray(slip_m) >= self.slip_fraction * self.pos_eps_m,
                    ~(ep <= self.pos_eps_m)])
        conds = [np.broadcast_to(c, ok.shape) for c in conds]
        mode = np.select(conds, names, default="orientation")
        return ok, np.where(ok, "none", mode)


@dataclasses.dataclass(frozen=True)
class Requirement:
    """What a plan must show to be certified: each sample judged by ``criterion``,
    success with probability at least ``probability``, claimed at ``confidence``
    (the one-sided Clopper-Pearson lower bound; :func:`robustness.certify`).

    Attributes:
      probability: the required success probability, in (0, 1).
      confidence: the confidence of the claim, in (0, 1).
      criterion: the :class:`SuccessCriterion` that judges each sample; None:
        the plan kind's (:meth:`SuccessCriterion.for_plan`, :meth:`for_plan`).

    A study's or certification's ``required:`` and ``eps:`` sections give this
    value (:meth:`sweeps.config.Evaluation.requirement`).
    """

    probability: float = REQUIRED_PROBABILITY
    confidence: float = CONFIDENCE
    criterion: Optional[SuccessCriterion] = None

    def __post_init__(self):
        for name in ("probability", "confidence"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and 0.0 < v < 1.0):
                raise ValueError(f"{name}: expected a number in (0, 1), got {v!r}")
            object.__setattr__(self, name, float(v))
        if self.criterion is not None and not isinstance(self.criterion, SuccessCriterion):
            raise ValueError(f"criterion: expected a robustness.SuccessCriterion or None, "
                             f"got {self.criterion!r}")

    def for_plan(self, plan) -> "Requirement":
        """This requirement with its criterion set: its own, else the plan kind's."""
        if self.criterion is not None:
            return self
        return dataclasses.replace(self, criterion=SuccessCriterion.for_plan(plan))

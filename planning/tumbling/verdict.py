"""The tumble planner's verdicts and their reasons.

* ``solved``: the returned plan, replayed by the exact kinematics on the part
  as given, ends **on the goal face** and within ``eps`` of the goal in the
  paper's metric (a wrong face is never a solution, whatever ``eps``); when
  ``tau_v`` merged faces that are split on the hull as given, on both
  (:mod:`planning.tumbling.given_hull`).  With
  ``tau_v > 0`` the paper's step-5 checks (eqs. 5, 6: a worst case over every
  part within ``tau_v``, far looser than the propagated error) are reported
  in the reason and in ``TumblePlan.step5_ok``; they are not required.
* ``not_solvable``: proved unreachable (the reachable headings or lattice
  positions of the goal face are all farther than ``eps``), or the search
  ended without a plan within ``eps`` (the reason says which).
* ``budget_exhausted``: the effort budget (operations, or the wall-clock cap)
  ran out before a plan within ``eps`` was found; the best plan found is
  returned.
"""
from __future__ import annotations

import math

__all__ = ["verdict", "fmt_count"]


def fmt_count(n: int) -> str:
    """A tumble count that may be astronomically large (a Python int)."""
    return str(n) if n < 10**12 else f"~1e{len(str(n)) - 1}"


def _budget_text(effort) -> str:
    ex = effort.exhausted
    if ex is not None and ex.clock:
        return f"the wall-clock cap (time_limit = {effort.time_limit:g} s)"
    cap = f"{int(effort.limit)} operations" if math.isfinite(effort.limit) else "no limit"
    return f"the effort budget (effort = {cap}, {effort.used} used)"


def _class_text(A) -> str:
    if A.near_tame:
        return (f"{A.reachable_class} reachable set at the part's tolerance tau_v = {A.tau_v:g} m; "
                f"{A.reachable_class_exact} for the coordinates as given")
    return f"{A.reachable_class} reachable set"


def _solved_reason(A, paper, eps, err, kind, n, exhausted, err_given=None) -> str:
    src = {"short": "short plan", "paper": "paper's construction"}.get(kind, kind)
    out = (f"{src}: {n} tumbles (paper's construction: {fmt_count(paper.n_tumbles)}), error "
           f"{err:.3g} <= eps {eps:g} ({_class_text(A)})")
    if err_given is not None:
        out += f"; on its hull as given, whose faces tau_v merged, error {err_given:.3g} <= eps"
    if A.tau_v > 0:
        if paper.step5_ok:
            out += f"; step 5 checks passed (tau_v = {A.tau_v:g})"
        else:
            out += ("; the paper's step-5 worst case over every part within tau_v does not "
                    "certify it: " + "; ".join(paper.step5_reasons))
    if exhausted:
        out += f"; the effort budget ran out ({exhausted}): a shorter plan may exist"
    return out


def _proved(A, paper, G: int, eps: float) -> list:
    """Reasons the goal is out of reach (empty if none is proved)."""
    parts = []
    tol_note = "" if A.all_rational_exact else " (at the part's tolerance)"
    if A.all_rational and paper.orientation_residual > eps:
        step = float(A.smallest_rotation) * math.pi
        parts.append(f"orientation residual {paper.orientation_residual:.4g} rad > eps: face {G} "
                     f"only reaches headings spaced {step:.4g} rad apart{tol_note}")
        beta = math.pi / A.q
        if beta > 2 * eps:
            parts.append(f"beta = pi/{A.q} = {beta:.4g} > 2 eps: orientation grid too coarse")
    elif A.all_rational and A.reachable_class == "discrete" and paper.position_residual > eps:
        parts.append(f"position residual {paper.position_residual:.4g} m > eps: the nearest "
                     f"reachable position (translation lattice, mesh Delta = "
                     f"{A.mesh_area:.4g} m^2{tol_note}) is too far")
        if 2 * math.sqrt(A.mesh_area / math.pi) >= eps:
            parts.append(f"lattice mesh too coarse: 2 sqrt(Delta/pi) = "
                         f"{2 * math.sqrt(A.mesh_area / math.pi):.4g} >= eps")
    return parts


def verdict(A, paper, G: int, eps: float, err: float, final_face: int, kind: str, n: int,
            shorten: bool, exhausted, effort, err_given=None) -> tuple[str, str]:
    """``(verdict, reason)`` for the best plan (``kind``, ``n`` tumbles, error
    ``err`` in the paper's metric, ending on ``final_face``) of a goal on face
    ``G`` (see the module doc).  ``exhausted``: the stage where the effort
    budget ran out, or None; ``effort``: the call's
    :class:`~planning.tumbling.effort.Effort`; ``err_given``: the error on the
    hull as given when its faces differ from those at tau_v (else None)."""
    given_miss = err_given is not None and err_given > eps
    if final_face == G and err <= eps and not given_miss:
        return "solved", _solved_reason(A, paper, eps, err, kind, n, exhausted, err_given)
    step5 = list(paper.step5_reasons) if A.tau_v > 0 and not paper.step5_ok else []
    if final_face == G and err <= eps:  # lands at tau_v, misses on the hull as given
        return "not_solvable", "; ".join([
            f"the best plan ({n} tumbles) lands within eps on the part's faces at tau_v = "
            f"{A.tau_v:g} m (error {err:.4g}) but not on its hull as given, whose faces "
            f"tau_v merged (error {err_given:.4g} > eps {eps:g}); give a smaller tau_v or a "
            "larger eps"] + step5)
    parts = _proved(A, paper, G, eps)
    if parts:
        return "not_solvable", "; ".join(parts + step5)
    if final_face != G:
        parts.append(f"no plan found: the best configuration reached is on face {final_face}, "
                     f"not the goal face {G}")
    if exhausted:
        parts.append(f"{_budget_text(effort)} ran out in {exhausted}; best plan found: {n} "
                     f"tumbles, error {err:.4g} > eps {eps:g}; raise effort, time_limit or eps")
        return "budget_exhausted", "; ".join(parts + step5)
    if not shorten and paper.word is None:
        parts.append(f"paper's construction needs {fmt_count(paper.n_tumbles)} tumbles, more "
                     "than this planner builds; use shorten=True")
    elif final_face == G:
        what = "dense reachable set: a longer plan exists; " if A.reachable_class != "discrete" else ""
        parts.append(f"search limit: best plan error {err:.4g} > eps {eps:g} ({what}"
                     "increase eps or the search budgets)")
    return "not_solvable", "; ".join(parts + step5)

"""What an engineer can change when a plan does not certify, in the words of the
config fields and flags that change it: the remedy of each failure mode, and
the ways out that no tolerance gives (a measured support, more fence friction,
another plan).  Read by ``nudge certify``'s next-steps line
(:func:`sweeps.certify.next_steps`) and by the tolerance design's drawing line
when no tolerance certifies (:func:`sweeps.tasks.design_rows`)."""
from __future__ import annotations

from kernels import ANY_COMPONENTS

#: what to change, by the dominant failure of a plan that did not certify
BY_FAILURE = {
    "slip": "a fence that grips better (friction.mu_f: the paper's experiments used a "
            "sandpaper-coated fence) or a plan that allows for slip (planner.min_fence_mu)",
    "wrong_edge": "a wider stability margin (planner.margin_deg) or longer reorient pushes "
                  "(planner.safety_factor)",
    "incomplete_reorientation": "longer reorient pushes (planner.safety_factor) or a wider "
                                "stability margin (planner.margin_deg)",
    "position": "tighter execution errors (execution:)",
    "orientation": "tighter execution errors (execution:)",
    "hull_changed": "a tighter vertex tolerance (tolerances.tau_v)",
    "combinatorics_changed": "a tighter vertex tolerance (tolerances.tau_v)",
    "wrong_face": "a smaller tumble accuracy (planner.tumble_eps) or a tighter vertex tolerance",
    "toppled": "the cell settings (physics:): a lower push height or a slower fence",
    "left_workspace": "a larger workspace (physics:) or shorter plans",
    "fence_strike": "the fence's clearance (physics:)",
}

SYNTHESIZE = "--synthesize (a plan chosen for these draws)"
SUPPORT = (f"a measured support (friction.support: {', '.join(ANY_COMPONENTS[:-1])} or "
           f"{ANY_COMPONENTS[-1]}) in place of any, which draws every family")
DESIGN = "--design (which tolerance drives the failures)"
FENCE_FRICTION = ("more fence friction (a fence that grips better: a higher friction.mu_f, or a "
                  "plan that allows for slip: planner.min_fence_mu)")
ANOTHER_PLAN = {"push": "another plan (planner.margin_deg, planner.safety_factor)",
                "tumble": "another plan (planner.tumble_eps)"}


def remedies(kind: str, mode=None, support: str = "any", synthesized: bool = False,
             designed: bool = False) -> list[str]:
    """The changes to try for a ``kind`` (``push``/``tumble``) plan whose dominant
    failure is ``mode``, leaving out what the run already did."""
    steps = []
    remedy = BY_FAILURE.get(str(mode))
    if remedy:
        steps.append(remedy)
    if kind == "push" and not synthesized:
        steps.append(SYNTHESIZE)
    if kind == "push" and support == "any":
        steps.append(SUPPORT)
    if not designed:
        steps.append(DESIGN)
    return steps


def beyond_tolerances(kind: str, support: str = "any", synthesized: bool = False,
                      more_draws: bool = False) -> str:
    """What can certify a plan that fails with every tolerance perfect (one
    clause): what no tolerance covers - the support, the fence friction, the
    plan itself; first more design draws when ``more_draws`` (the failures
    left are few enough that more draws could show the requirement)."""
    ways = ["more design draws (design.n_samples)"] if more_draws else []
    if kind == "push" and support == "any":
        ways.append(SUPPORT)
    if kind == "push":
        ways.append(FENCE_FRICTION)
        ways.append(SYNTHESIZE if not synthesized else ANOTHER_PLAN["push"])
    else:
        ways.append(ANOTHER_PLAN["tumble"])
    return "what would: " + "; ".join(ways)

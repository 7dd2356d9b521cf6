"""The support families a pushed part may rest on: one table, every list of
their names read from it (pure Python, no JAX: the command lines' parsers read
it before any work).  What each family is, and how its points and loads are
drawn, is :mod:`kernels.support`'s docstring.
"""
from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Family:
    """One support family: a row of :data:`TABLE`, the one place a family is
    declared (every list of names in nudge is read from the table).

    Attributes:
      name: the family's name (configs, tables; its row is the sampler's code).
      in_any: a component of the ``any`` mixture (drawn with equal probability).
      planned: its ``c`` on a part follows from the part (:func:`kernels.support.family_c_range`),
        so a plan's push distances can be made valid for it (``planner.support``).
      feet: the MuJoCo scene realises it (feet, or the part's own corners);
        False: a model only.
      c_given: its ``c`` range is configured (``friction.c``), not the part's.
      varies: its ``c`` differs from sample to sample on one part (rigid: which
        three corners carry it; points: the sampled pressure); a ``c_given``
        family varies when its range has width.
    """

    name: str
    in_any: bool
    planned: bool
    feet: bool
    c_given: bool
    varies: bool


#: The support families (the order is the codes' order: never reorder, append).
#: ``points`` is the sampled Dirichlet distribution of :mod:`robustness.support`
#: (model only: its loads cannot be realised by feet).
TABLE = (
    Family("rigid", in_any=True, planned=True, feet=True, c_given=False, varies=True),
    Family("uniform", in_any=True, planned=True, feet=True, c_given=False, varies=False),
    Family("ring", in_any=True, planned=True, feet=True, c_given=False, varies=False),
    Family("tripod", in_any=True, planned=False, feet=True, c_given=True, varies=False),
    Family("points", in_any=False, planned=False, feet=False, c_given=False, varies=True),
)
#: the mixture of the ``in_any`` families (a configuration's default: the support unknown);
#: for the planner, Peshkin's distances, valid for every support
ANY = "any"
#: named support families, in code order
FAMILIES = tuple(f.name for f in TABLE)
#: the row of each family
FAMILY = {f.name: f for f in TABLE}
#: integer codes of the families (the sampler's per-sample ``family`` column)
CODES = {name: i for i, name in enumerate(FAMILIES)}
#: the names a configuration may give (``friction.support``)
SUPPORT_FAMILIES = (ANY,) + FAMILIES
#: the components of the ``any`` mixture, drawn with equal probability
ANY_COMPONENTS = tuple(f.name for f in TABLE if f.in_any)
#: the families whose ``c`` range a part determines (:func:`kernels.support.family_c_range`)
PLANNED_FAMILIES = tuple(f.name for f in TABLE if f.planned)
#: the supports a plan's distances can be valid for (``planner.support``)
PLAN_SUPPORTS = (ANY,) + PLANNED_FAMILIES
#: the supports the MuJoCo scene realises (``any``: when its components all have feet)
REALISABLE_SUPPORTS = ((ANY,) if all(FAMILY[n].feet for n in ANY_COMPONENTS) else ()) + tuple(
    f.name for f in TABLE if f.feet)
#: the supports whose ``c`` is drawn afresh for every sample of one part (a
#: ``c_given`` family's too when its range has width)
VARYING_SUPPORTS = (ANY,) + tuple(f.name for f in TABLE if f.varies)

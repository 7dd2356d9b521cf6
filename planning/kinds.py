"""The plan interface: what every plan type declares, and the list of plan types.

A plan type is a frozen dataclass that carries, besides its data:

* ``kind`` (a class attribute, a ``str``): the key of the dispatch tables of the
  layers above (:data:`robustness.kinds.KINDS`: the sampler's draw, the replay,
  the physics rollout, the bound, the defaults of each kind), read instead of
  rediscovering a plan's kind from its attributes;
* ``n_steps``: its steps (pushes, tumbles);
* ``verdict``: ``"solved"`` for a plan that reaches its goal (a push plan always:
  the planner returns verified plans only), else the planner's verdict;
* ``nominal_part()``: the nominal part the plan was made for (a
  :class:`kernels.Polygon` or :class:`kernels.Polyhedron`);
* ``draw_shape()``: the keywords ``n_vertices``, ``dim`` and ``n_pushes`` or
  ``n_tumbles`` of one sample's draws (:meth:`robustness.Sampler.sample`).

:data:`PLAN_TYPES` lists every plan type by kind; a test holds it equal to the plan
classes ``planning`` exports and holds every kind to an entry of the robustness
table (or a stated reason why it has none).
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

from planning.pushing.plan import PushPlan
from planning.pushing.sensorless import SensorlessPlan
from planning.tumbling.plan import TumblePlan


@runtime_checkable
class Plan(Protocol):
    """The plan interface (module docstring)."""

    kind: str

    @property
    def n_steps(self) -> int: ...

    @property
    def verdict(self) -> str: ...

    def nominal_part(self): ...

    def draw_shape(self) -> dict: ...

    def to_dict(self) -> dict: ...


#: every plan type, by its kind
PLAN_TYPES = {cls.kind: cls for cls in (PushPlan, TumblePlan, SensorlessPlan)}

#: the methods and properties of the plan interface
INTERFACE = ("kind", "n_steps", "verdict", "nominal_part", "draw_shape", "to_dict")

__all__ = ["PLAN_TYPES", "INTERFACE", "Plan"]

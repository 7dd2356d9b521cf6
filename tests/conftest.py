"""Shared pytest configuration: the planner and its tests run in float64, and
every hypothesis test is derandomized (fixed seed: the same examples on every
run, no flaky CI) with no per-example deadline (JAX compiles on first use)."""
import jax
from hypothesis import settings

jax.config.update("jax_enable_x64", True)

settings.register_profile("nudge", derandomize=True, deadline=None, print_blob=True)
settings.load_profile("nudge")

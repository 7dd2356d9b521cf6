"""Shared pytest configuration.

* JAX runs with its default (float32) global setting: the library must compute
  in float64 where it promises to, by itself (scoped x64).  Tests that call
  kernels directly on float64 arrays carry the ``float64`` marker (module-level
  ``pytestmark``), which runs each of them inside ``jax.enable_x64(True)``.
* Every hypothesis test is derandomized (fixed seed: the same examples on every
  run, no flaky CI) with no per-example deadline (JAX compiles on first use).
* No persistent compilation cache (``NUDGE_JAX_CACHE`` empty, inherited by the
  commands the tests start): the tests neither read a user's cache nor write
  one; the tests of the cache name their own folder.
"""
import os

os.environ["NUDGE_JAX_CACHE"] = ""

import jax  # noqa: E402
import pytest
from hypothesis import settings

settings.register_profile("nudge", derandomize=True, deadline=None, print_blob=True)
settings.load_profile("nudge")


@pytest.fixture(autouse=True)
def _scoped_float64(request):
    """Run tests marked ``float64`` with 64-bit JAX types (scoped to the test)."""
    if request.node.get_closest_marker("float64") is None:
        yield
        return
    with jax.enable_x64(True):
        yield

"""Shared pytest configuration.

* JAX runs with its default (float32) global setting: the library must compute
  in float64 where it promises to, by itself (scoped x64).  Tests that call
  kernels directly on float64 arrays carry the ``float64`` marker (module-level
  ``pytestmark``), which runs each of them inside ``jax.enable_x64(True)``.
* Every hypothesis test is derandomized (fixed seed: the same examples on every
  run, no flaky CI) with no per-example deadline (JAX compiles on first use).
* The suite compiles thousands of XLA executables in one process, and each CPU
  executable holds memory maps of its own: past the kernel's limit
  (``vm.max_map_count``, 65,530 by default) the next compilation's mmap fails and
  XLA segfaults (CI exit 139 at 78-91% of the suite).  After a test that leaves
  the process above :data:`robustness.compiled.MAX_MAPS` maps, JAX's compilation caches are cleared
  (the next test compiles again what it needs).
* The persistent compilation cache is one folder for the whole run
  (``NUDGE_JAX_CACHE``; made by the first pytest process, inherited by xdist's
  workers and by the commands the tests start; removed at exit), used by the
  tests' own processes too: the tests neither read a user's cache nor write
  one, the dozens of ``nudge sweep`` / ``nudge certify`` subprocesses load the
  kernels an earlier one compiled instead of compiling them again (a small
  margins study: 44 s cold, 20 s warm), a kernel one worker compiled is loaded
  by the other, and a test after :func:`_release_executables` loads what it
  needs again (the suite's test time, 2 cores: 1,841 s with a folder per worker
  used only by subprocesses, 1,630 s shared).  The tests of the cache name
  folders of their own.
"""
import atexit
import os
import shutil
import tempfile

#: The suite's cache folder, made by the first pytest process (xdist's controller, or
#: pytest alone) and inherited by its workers: one folder for the whole run.
SUITE_CACHE_ENV = "NUDGE_TESTS_JAX_CACHE"
if SUITE_CACHE_ENV not in os.environ:
    os.environ[SUITE_CACHE_ENV] = tempfile.mkdtemp(prefix="nudge-tests-jax-cache-")
    atexit.register(shutil.rmtree, os.environ[SUITE_CACHE_ENV], ignore_errors=True)
os.environ["NUDGE_JAX_CACHE"] = os.environ[SUITE_CACHE_ENV]

import jax  # noqa: E402

jax.config.update("jax_compilation_cache_dir", os.environ[SUITE_CACHE_ENV])
# two CPU devices, as a command line has on CI's two cores (sweeps.terminal.run_main):
# a batch's compiled replays spread over both (robustness.replay.replay_devices)
jax.config.update("jax_num_cpu_devices", 2)
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
import pytest
from hypothesis import settings

from robustness import release_executables

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


@pytest.fixture(autouse=True)
def _release_executables():
    """Keep the process under the kernel's memory-map limit (module docstring;
    :func:`robustness.release_executables`)."""
    yield
    release_executables()


#: Test files heaviest first, by their measured time (``--durations``, 2 cores, seconds
#: of one worker; issue 20, December 2026): the README runs two xdist workers on whole
#: files (``--dist loadfile``), and a file started last holds the run open alone.
#: xdist's default order (most tests first) started test_sweep.py among the last;
#: heaviest first is the longest-processing-time rule.
HEAVY_FIRST = (
    "test_pose_planner.py",       # ~160
    "test_sweep.py",              # ~160
    "test_pose_options.py",       # ~95
    "test_synthesis.py",          # ~90
    "test_certify.py",            # ~85
    "test_support_families.py",   # ~75
    "test_cad.py",                # ~55
    "test_limit_surface.py",      # ~45
    "test_tumble_planner.py",     # ~40
    "test_evaluate.py",           # ~35
    "test_tolerance_design.py",   # ~35
    "test_tumble_cli.py",         # ~35
    "test_samplers.py",           # ~30
    "test_push_cli.py",           # ~30
    "test_quasistatic.py",        # ~25
    "test_runner_reference.py",   # ~25
    "test_hulls.py",              # ~25
)


def pytest_configure(config):
    """Keep the collection order below when xdist distributes whole files."""
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(config, items):
    """Heaviest files first (:data:`HEAVY_FIRST`), the rest in their usual order."""
    rank = {name: i for i, name in enumerate(HEAVY_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))

"""Scoped float64: planners, exact replays and bounds compute in float64
whatever the caller's global JAX setting, and change no global setting.

``jax.enable_x64(True)`` is a context manager local to the calling thread; the
decorator below wraps a whole public entry point in it, so that every array it
creates and every function it jit-compiles is float64 (a jitted function traced
under x64 is cached apart from its float32 twin).  Monte-Carlo kernels do not
use it: they take the dtype of the arrays they are given.
"""
from __future__ import annotations

import functools

import jax


def float64(fn):
    """Decorator: run ``fn`` with 64-bit JAX types enabled (scoped; the caller's
    setting is back in force when it returns or raises)."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with jax.enable_x64(True):
            return fn(*args, **kwargs)

    return wrapper

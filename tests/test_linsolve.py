"""The closed-form small solves (kernels.linsolve) against numpy's LAPACK, on
the hard cases: a zero leading pivot, rows scaled apart by many orders, nearly
singular symmetric matrices (the supports' ridge-regularised normal
equations), and batches."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, strategies as st

from kernels.linsolve import det2, det3, solve2, solve3

pytestmark = pytest.mark.float64

ENTRY = st.floats(-1e3, 1e3, allow_nan=False, allow_subnormal=False)


def _backward_error(A, x, b):
    """|A x - b| / (|A| |x| + |b|): of the order of eps for a backward-stable solve."""
    r = np.einsum("...ij,...j->...i", A, x) - b
    return np.linalg.norm(r, axis=-1) / (np.linalg.norm(A, axis=(-2, -1)) * np.linalg.norm(x, axis=-1)
                                         + np.linalg.norm(b, axis=-1))


@given(st.lists(ENTRY, min_size=12, max_size=12), st.integers(-12, 12))
def test_solve3_is_backward_stable(v, scale):
    A = np.asarray(v[:9]).reshape(3, 3)
    A[1] *= 10.0 ** scale                     # rows scaled apart: pivoting matters
    b = np.asarray(v[9:])
    if abs(np.linalg.det(A)) <= 1e-300 or np.linalg.cond(A) > 1e14:
        return
    x = np.asarray(solve3(jnp.asarray(A), jnp.asarray(b)))
    assert _backward_error(A, x, b) < 1e-14
    ref = np.linalg.solve(A, b)
    assert np.linalg.norm(x - ref) <= 1e-14 * np.linalg.cond(A) * np.linalg.norm(ref)


def test_solve3_pivots_past_a_zero_leading_entry():
    A = np.array([[0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 2.0]])
    assert np.allclose(np.asarray(solve3(jnp.asarray(A), jnp.asarray([1.0, 2.0, 4.0]))),
                       [1.0, 1.0, 2.0], atol=0, rtol=1e-15)
    tiny = A.copy()
    tiny[0, 0] = 1e-18                        # without pivoting: 1e18 growth, wrong digits
    x = np.asarray(solve3(jnp.asarray(tiny), jnp.asarray([1.0, 2.0, 4.0])))
    assert np.allclose(x, np.linalg.solve(tiny, [1.0, 2.0, 4.0]), rtol=1e-15, atol=1e-15)


def test_nearly_singular_normal_equations_and_batches():
    """Symmetric ``U diag(1, 1e-6, 1e-12) U^T + 1e-13 I`` (the equilibrium
    weights' Hessians), 500 at once: backward errors of a few eps; the
    determinants against numpy's."""
    rng = np.random.default_rng(0)
    U = np.linalg.qr(rng.normal(size=(500, 3, 3)))[0]
    A = np.einsum("nij,j,nkj->nik", U, [1.0, 1e-6, 1e-12], U) + 1e-13 * np.eye(3)
    b = rng.normal(size=(500, 3))
    x = np.asarray(solve3(jnp.asarray(A), jnp.asarray(b)))
    assert x.shape == (500, 3) and np.max(_backward_error(A, x, b)) < 1e-15
    G = rng.normal(size=(500, 3, 3))
    assert np.allclose(np.asarray(det3(jnp.asarray(G))), np.linalg.det(G), rtol=1e-12, atol=1e-12)
    S = A[:, :2, :2]
    x2 = np.asarray(solve2(jnp.asarray(S), jnp.asarray(b[:, :2])))
    assert np.max(_backward_error(S, x2, b[:, :2])) < 1e-14
    ref = np.linalg.solve(S, b[:, :2, None])[..., 0]     # forward: within cond(S) eps of LAPACK
    assert np.all(np.linalg.norm(x2 - ref, axis=1)
                  <= 1e-15 * np.linalg.cond(S) * np.linalg.norm(ref, axis=1))
    assert np.allclose(np.asarray(det2(jnp.asarray(S))), np.linalg.det(S), rtol=1e-12)


def test_no_lapack_call_and_singular_is_not_finite():
    A = jnp.zeros((4, 3, 3))
    text = jax.jit(solve3).lower(A, jnp.ones((4, 3))).as_text()
    assert "lapack" not in text and "custom_call" not in text
    assert not np.all(np.isfinite(np.asarray(solve3(A, jnp.ones((4, 3))))))
    assert not np.all(np.isfinite(np.asarray(solve2(A[:, :2, :2], jnp.ones((4, 2))))))


def test_no_lapack_backed_solve_in_the_jax_code():
    """Source scan of the layers that compile (kernels, planning, robustness): no
    ``jnp.linalg`` call but ``norm`` and no ``jax.scipy.linalg`` / ``lax.linalg``
    (on the CPU those are LAPACK custom calls, which deadlocked compiled replays
    running at once: kernels.linsolve); numpy's ``np.linalg`` on the host is fine."""
    import pathlib
    import re

    root = pathlib.Path(__file__).resolve().parents[1]
    bad = re.compile(r"jnp\.linalg\.(?!norm\b)\w+|jax\.scipy\.linalg|lax\.linalg|jsp\.linalg")
    found = [f"{p.relative_to(root)}:{i}: {line.strip()}"
             for pkg in ("kernels", "planning", "robustness") for p in (root / pkg).rglob("*.py")
             for i, line in enumerate(p.read_text().splitlines(), 1)
             if bad.search(line.split("#")[0]) and "``" not in line]
    assert not found, "\n".join(found)
    assert bad.search("d = jnp.linalg.solve(A, b)") and not bad.search("jnp.linalg.norm(v)")

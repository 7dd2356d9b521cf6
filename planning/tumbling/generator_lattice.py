"""The lattice of the translation generators (Marigo-Bicchi Sec. III, eq. (3)).

Every generator ``v`` (closed form, :mod:`planning.tumbling.generators`) is
written as ``v = a v_a + b v_b`` in two independent ones (the most orthogonal
pair among the long generators); ``a, b`` are replaced by rationals and the
lattice ``[X1 X2 0] = V U`` of the rational coefficient vectors is computed by
Hermite normal form (:func:`planning.lattice.lattice_basis`), with its mesh
area ``Delta``.

Which rationals (``tau_g``, the generator-coefficient tolerance):

* ``tau_g`` > 0: the smallest-denominator rational within ``tau_g`` (the
  paper's lattice approximation);
* ``tau_g`` None or 0 (automatic): the coefficients' exact rational values when
  every one is detected rational (``tau_g_used = 0``); otherwise, when the
  part has a tolerance (``gen_err`` > 0, metres: the paper's error bound
  ``l tau_v + d_max Delta_gen`` of a generator), the rationals that tolerance
  determines (:func:`planning.rationals.rational_at_tolerance`;
  ``tau_g_used`` = the largest coefficient tolerance); failing both, the
  smallest-denominator rationals within ``DEFAULT_TAU_G``.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Optional

import numpy as np

from planning.lattice import lattice_basis
from planning.rationals import best_rational_within, rational_at_tolerance

__all__ = ["GeneratorLattice", "generator_lattice", "rational_coef", "coefficient_tolerances",
           "independent_pair", "COEF_TOL", "COEF_MAX_DEN", "DEFAULT_TAU_G"]

#: tau_g == None and generator coefficients that are not (detected) rational.
DEFAULT_TAU_G = 1e-6
#: Coefficient rationality test (Remark 3): |a - r/s| <= COEF_TOL * max(1, |a|)
#: with s <= COEF_MAX_DEN (false-positive rate ~1e-3 per coefficient; a class
#: is called discrete only if *all* coefficients pass).
COEF_TOL = 1e-9
COEF_MAX_DEN = 1000


def rational_coef(a: float, tol: Optional[float] = None) -> Optional[Fraction]:
    """The rational value of a generator coefficient, or None.

    Exact detection first: within ``COEF_TOL * max(1, |a|)`` of a rational of
    denominator <= ``COEF_MAX_DEN``.  Else, with ``tol`` (> 0, an absolute
    tolerance on ``a`` from the part's tolerance), the rational that tolerance
    determines (:func:`planning.rationals.rational_at_tolerance`)."""
    r = best_rational_within(a, COEF_TOL * max(1.0, abs(a)))
    if r.denominator <= COEF_MAX_DEN:
        return r
    if tol:
        return rational_at_tolerance(a, tol, COEF_MAX_DEN)
    return None


def coefficient_tolerances(B: np.ndarray, coefs, gen_err: float) -> list[float]:
    """First-order tolerance of each coefficient pair ``(a, b)`` of
    ``v = a v_a + b v_b`` (``B = [v_a v_b]`` as columns) when every generator
    is known to ``gen_err`` metres: ``|B^-1|_2 gen_err (1 + |a| + |b|)``."""
    binv = float(np.linalg.norm(np.linalg.inv(B), 2))
    return [binv * gen_err * (1.0 + abs(float(c[0])) + abs(float(c[1]))) for c in coefs]


def independent_pair(vecs: np.ndarray, idx: list) -> Optional[tuple[int, int, float]]:
    """The most orthogonal pair among the long vectors (norm >= 1/4 of the
    longest; ties to the longer pair): ``(i, j, |sin angle|)`` with ``i, j``
    taken from ``idx`` (rows of ``vecs``), or None for fewer than two."""
    norms = np.linalg.norm(vecs, axis=1)
    big = [k for k in range(len(idx)) if norms[k] >= 0.25 * norms.max()]
    best = None
    for ia in range(len(big)):
        va = vecs[big[ia]]
        for ib in range(ia + 1, len(big)):
            vb = vecs[big[ib]]
            s = abs(va[0] * vb[1] - va[1] * vb[0]) / (np.linalg.norm(va) * np.linalg.norm(vb))
            key = (round(s, 9), -(np.linalg.norm(va) + np.linalg.norm(vb)))
            if best is None or key > best[0]:
                best = (key, idx[big[ia]], idx[big[ib]])
    if best is None:
        return None
    return best[1], best[2], best[0][0]


@dataclass(frozen=True)
class GeneratorLattice:
    """The eq. (3) lattice: ``coefficient_basis`` (indices of ``v_a, v_b``,
    ``(-1, -1)`` if none), ``rationals`` (per generator the Fraction pair, or
    None), ``lattice_basis`` ``(X1, X2)`` (float metres), ``lattice_basis_coef``
    (the same in the ``(v_a, v_b)`` basis, Fractions), ``U`` (unimodular, rows =
    generators), ``rank``, ``mesh_area`` (``Delta``, m^2) and ``tau_g_used``."""

    coefficient_basis: tuple
    rationals: list
    lattice_basis: tuple
    lattice_basis_coef: tuple
    U: tuple
    rank: int
    mesh_area: float
    tau_g_used: Optional[float]


def _rationals(coefs, tau_g, tols) -> tuple[list, Optional[float]]:
    """Rational coefficients and the tolerance used (see the module doc)."""
    if tau_g:
        return [[best_rational_within(float(x), float(tau_g)) for x in cf] for cf in coefs], tau_g
    rats = [[rational_coef(float(x)) for x in cf] for cf in coefs]
    if all(r is not None for pr in rats for r in pr):
        return rats, 0.0
    if tols is not None:
        tol_rats = [[r if r is not None else rational_coef(float(x), t) for r, x in zip(pr, cf)]
                    for pr, cf, t in zip(rats, coefs, tols)]
        if all(r is not None for pr in tol_rats for r in pr):
            return tol_rats, float(max(tols))
    return [[r if r is not None else best_rational_within(float(x), DEFAULT_TAU_G)
             for r, x in zip(pr, cf)] for pr, cf in zip(rats, coefs)], DEFAULT_TAU_G


def generator_lattice(gens: list, tau_g: Optional[float], gen_err: float = 0.0) -> GeneratorLattice:
    """Eq. (3) and the Hermite normal form for the generators ``gens`` (dicts
    with ``vector_closed_form``); see the module doc.  Sets each generator's
    ``vector_rational`` (Fraction pair, or None when no basis exists)."""
    scale = max([abs(complex(*gg["vector_closed_form"])) for gg in gens] + [0.0])
    nz = [i for i, gg in enumerate(gens)
          if abs(complex(*gg["vector_closed_form"])) > 1e-9 * max(scale, 1e-300)]
    out = GeneratorLattice((-1, -1), [None] * len(gens), ((0.0, 0.0), (0.0, 0.0)),
                           ((Fraction(0), Fraction(0)), (Fraction(0), Fraction(0))), (), 0, 0.0,
                           tau_g)
    pair = independent_pair(np.array([gens[i]["vector_closed_form"] for i in nz]), nz) if nz else None
    if pair is None or not pair[2] > 1e-9:
        for gg in gens:
            gg.setdefault("vector_rational", None)
        return out
    a_i, b_i, _ = pair
    B = np.array([gens[a_i]["vector_closed_form"], gens[b_i]["vector_closed_form"]]).T
    Binv = np.linalg.inv(B)
    coefs = [Binv @ np.array(gg["vector_closed_form"]) for gg in gens]
    tols = coefficient_tolerances(B, coefs, gen_err) if gen_err > 0 else None
    rats, tau_g_used = _rationals(coefs, tau_g, tols)
    rats[a_i] = [Fraction(1), Fraction(0)]
    rats[b_i] = [Fraction(0), Fraction(1)]
    for gg, pr in zip(gens, rats):
        gg["vector_rational"] = (pr[0], pr[1])
    Xcl, U_, rank = lattice_basis([tuple(pr) for pr in rats])
    U = tuple(tuple(int(x) for x in row) for row in U_)
    X, Xc, mesh = out.lattice_basis, out.lattice_basis_coef, 0.0
    if rank == 2:
        Xc = (tuple(Xcl[0]), tuple(Xcl[1]))
        X1 = B @ np.array([float(Xc[0][0]), float(Xc[0][1])])
        X2 = B @ np.array([float(Xc[1][0]), float(Xc[1][1])])
        X = ((float(X1[0]), float(X1[1])), (float(X2[0]), float(X2[1])))
        mesh = abs(X1[0] * X2[1] - X1[1] * X2[0])
    return GeneratorLattice((a_i, b_i), [tuple(pr) for pr in rats], X, Xc, U, rank, float(mesh),
                            tau_g_used)

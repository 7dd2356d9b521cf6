"""Short tumble plans (beyond the paper): cores, rotation loops and
translation loops, assembled and checked exactly.

A plan from face ``F`` to face ``G`` is built as ``T . R . A . B^-1``:

* the **core** ``A B^-1`` (:mod:`planning.tumbling.cores`): walks from both
  ends (:mod:`planning.tumbling.walks`) meeting on a face, matched on the
  heading -- exactly the nearest reachable heading when every defect angle is
  a rational multiple of pi (the reachable headings are a coset of the
  rotation step), within ``eps/2`` otherwise;
* for irrational defect angles also cheap cores of any heading, whose heading
  is then fixed by ``R``, a product of short rotation loops
  (:mod:`planning.tumbling.rotation_table`);
* ``T``, integer counts of translation loops (:mod:`planning.tumbling.loops`;
  they commute) giving the translation left by ``R . core``: exactly on the
  lattice of a discrete reachable set
  (:mod:`planning.tumbling.translation_lattice`), approximately on a dense one
  (:mod:`planning.tumbling.translation_dense`).

Several cores are tried; each candidate word is purged and its effect is
computed exactly with :class:`~planning.tumbling.motions.TumbleTable`; the
shortest one within ``eps`` wins (the planner then verifies it with the JAX
kernel).  :class:`ShortPlanner` holds the per-analysis tables and is cached by
the planner with the analysis.

A **near-tame** part (rational angles or a lattice only at its tolerance,
``TumbleAnalysis.near_tame``) is planned, with ``at_tolerance=True``, on its
rational model: walk headings keyed on the model's rotation grid and loops
recognised to within the part's tolerance; ``at_tolerance=False`` plans on
the exact class of the coordinates as given.

Effort: the planner's build and every plan call are metered in operations
(:mod:`planning.tumbling.effort`); a candidate word is only built when its
length (known before building it) fits the remaining budget.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from kernels import wrap_angle_np
from planning.lattice import closest_lattice_point
from planning.tumbling.cores import N_CORES, CoreIndex
from planning.tumbling.effort import VECTOR_OPS, BudgetExhausted, Effort
from planning.tumbling.loops import LoopFinder, LoopTolerances
from planning.tumbling.motions import Motion
from planning.tumbling.reachability import reduced_basis
from planning.tumbling.rotation_table import RotationTables
from planning.tumbling.translation_dense import DenseLoops
from planning.tumbling.translation_lattice import LatticeLoops
from planning.tumbling.walks import Walks, akey, enumerate_walks, grid_key
from planning.tumbling.words import concat, inverse, loop_power_length, power, purge

__all__ = ["ShortPlanner", "ShortResult", "tame_model_usable", "FWD_BUDGET", "BWD_BUDGET",
           "TAME_STEP_MARGIN"]

#: Walks enumerated from the start face / from each goal face.
FWD_BUDGET = 20_000
BWD_BUDGET = 10_000
#: Candidate plans assembled and evaluated per goal; beyond them, those
#: whose estimate ties the last one's, while at most TIE_EVAL_CAP tumbles long
#: (cores tied in the estimate differ in what cancels at their junction with
#: the translation loops, which the estimate does not see).
N_EVALUATED = 8
TIE_EVAL_CAP = 4096
#: Core candidates (walk pairs) examined per distinct core word kept: many walk
#: pairs purge to the same core, and N_CORES distinct ones are kept.
CORE_POOL = 16


@dataclass
class ShortResult:
    """The best short plan found: its ``word`` (None when the effort budget
    ran out before any plan was assembled), exact ``motion`` (start frame),
    ``error`` (paper's metric, the face being right by construction),
    residuals (rad, m), the lengths of its core and translation part, and
    ``exhausted``: the stage where the effort budget ran out (None if it did
    not)."""

    word: Optional[tuple]
    motion: Motion
    error: float
    orientation_residual: float
    position_residual: float
    core_length: int
    translation_length: int
    exhausted: Optional[str] = None


def _akey(a, faces):
    return akey(a)


#: A near-tame part is planned on its rational model only when the model's
#: rotation step is at least this many times the angle tolerance Delta_beta
#: (walk headings then stay near the model's grid over many tumbles).
TAME_STEP_MARGIN = 64


def tame_model_usable(A) -> bool:
    """Whether a near-tame analysis' rational model can guide the search (see
    ``TAME_STEP_MARGIN``)."""
    step = float(A.smallest_rotation) * math.pi
    return bool(A.near_tame and step >= TAME_STEP_MARGIN * A.static_bounds["Delta_beta"])


class ShortPlanner:
    """Short plans for one :class:`~planning.tumbling.analysis.TumbleAnalysis`
    (start face ``F``).

    Args:
      A: the analysis; fwd_budget / bwd_budget: walks enumerated from F / from
        each goal face.
      at_tolerance: plan on the class at the part's tolerance (True) or on the
        exact class (False); they differ only for a near-tame part.
      effort: an :class:`~planning.tumbling.effort.Effort` consulted while
        building (nothing is charged; the caller charges ``cost``).

    Attributes: ``regime`` (``exact_lattice``, ``exact_heading`` or
    ``dense``), ``near_tame`` (planning on a tolerance model), ``gens``
    (translation loops), ``rho`` (tumbles per metre of the most efficient
    loop), ``cost`` (operations to build it).
    """

    def __init__(self, A, fwd_budget: int = FWD_BUDGET, bwd_budget: int = BWD_BUDGET,
                 at_tolerance: bool = True, effort: Optional[Effort] = None):
        self.A = A
        self.table = A.table
        self.F = F = A.start_face
        P = A.polyhedron
        hv = P.vertices[list(P.hull_vertices)]
        self.scale = float(np.max(np.linalg.norm(hv - hv.mean(0), axis=1))) * 2.0
        all_rat, cls = ((A.all_rational, A.reachable_class) if at_tolerance else
                        (A.all_rational_exact, A.reachable_class_exact))
        self.regime = ("exact_lattice" if cls == "discrete" else "exact_heading") if all_rat else "dense"
        self.near_tame = bool(at_tolerance and tame_model_usable(A) and self.regime != "dense")
        self.fwd_budget, self.bwd_budget = fwd_budget, bwd_budget
        self._setup_keys()
        self.cost = 0
        self.fwd = enumerate_walks(self.table, F, fwd_budget, self.tol.pos, key=self.key_at(F),
                                   effort=effort)
        self.cost += self.fwd.cost
        self.finder = LoopFinder(self.table, F, self.fwd, self.tol, self.key_at(F))
        pool = self.finder.pool()
        gens = self.finder.translation_loops(pool)
        self.lattice = self.dense_loops = None
        if self.regime == "exact_lattice":
            self.lattice = self._lattice_loops(gens, pool, effort)
            gens = self.lattice.gens
            self.cost += self.lattice.cost
        elif gens:
            self.dense_loops = DenseLoops(gens, self.scale)
            self.cost += self.dense_loops.cost
        self.cost += self.finder.cost + len(pool[0]) // VECTOR_OPS
        self.gens = gens
        eff = [g.length / abs(g.t) for g in gens]
        self.rho = min(eff) if eff else 0.0
        self.cores = CoreIndex(self.fwd, self.key_at(F), self.rho)
        self.cost += len(self.fwd) // VECTOR_OPS + 1
        if effort is not None:
            effort.check(self.cost, "short-plan tables")
        self._bwd: dict = {}
        self._rot: Optional[RotationTables] = None
        self._rot_cost = 0

    # ------------------------------------------------------------- set-up
    def _setup_keys(self):
        A = self.A
        if not self.near_tame:
            self.tol = LoopTolerances.exact(self.scale)
            self._offsets = None
            return
        step = float(A.smallest_rotation) * math.pi
        spacing = self.scale
        if A.rank == 2 and A.mesh_area > 0:
            b1, _ = reduced_basis(A.lattice_basis)
            spacing = float(np.linalg.norm(b1))
        self.tol = LoopTolerances.near_tame(self.scale, A.generator_error, step, spacing)
        self._step = step
        self._offsets = np.array([A.development[f][2] for f in range(A.polyhedron.n_faces)])

    def key_at(self, root: int):
        """Heading key of walks rooted at face ``root``: :func:`akey`, or for a
        near-tame part the model's rotation grid (face ``f``'s headings lie on
        ``dev(f) - dev(root) + step Z``)."""
        if self._offsets is None:
            return _akey
        return grid_key(self._step, self._offsets - self._offsets[root])

    def _lattice_loops(self, gens, pool, effort) -> LatticeLoops:
        finder, base = self.finder, self.cost

        def make(s, a):
            g = finder.make(s, a)
            if effort is not None:
                effort.check(base + finder.cost, "lattice loops")
            return g

        def from_word(w):
            g = finder.from_word(w)
            if effort is not None:
                effort.check(base + finder.cost, "lattice loops")
            return g

        extra = [g["word"] for g in self.A.translation_generators if g["word"] is not None]
        return LatticeLoops(self.A.lattice_basis, gens, pool, make, from_word, extra)

    # -------------------------------------------------------- lazy tables
    def bwd(self, G: int, effort: Optional[Effort] = None) -> Walks:
        """Walks from goal face ``G`` (cached; their cost charged once per call)."""
        if G == self.F:
            return self.fwd
        if G not in self._bwd:
            self._bwd[G] = enumerate_walks(self.table, G, self.bwd_budget, self.tol.pos,
                                           key=self.key_at(G), effort=effort)
        B = self._bwd[G]
        if effort is not None:
            effort.charge_once(B, B.cost, "walk enumeration")
        return B

    def rotations(self, effort: Optional[Effort] = None) -> RotationTables:
        """The rotation loops' tables (cached; the loops' cost charged once per call)."""
        if self._rot is None:
            before = self.finder.cost
            loops = self.finder.rotation_loops([r["word"] for r in self.A.rotation_generators])
            self._rot = RotationTables(loops, self.F)
            self._rot_cost = self.finder.cost - before
        if effort is not None:
            effort.charge_once(self._rot, self._rot_cost, "rotation loops")
        return self._rot

    # ------------------------------------------------------------ helpers
    def _motion(self, word: tuple, effort: Effort) -> Motion:
        effort.charge(len(word), "word effects")
        return self.table.word_motion(self.F, word)

    def predicted_length(self, coef: dict, core: tuple) -> int:
        """Tumbles of ``T . core`` before purging across the blocks."""
        return len(core) + sum(loop_power_length(self.gens[b].length, self.gens[b].cancel, c)
                               for b, c in coef.items())

    def _affordable(self, t: complex, core: tuple, effort: Effort) -> dict:
        """A coarse translation that fits the remaining budget, for a plan too
        long to build: on a dense set a coarse combination of loops
        (:meth:`DenseLoops.coarse`), else none (the core alone)."""
        if self.dense_loops is not None:
            return self.dense_loops.coarse(t, effort.remaining / 2 - len(core), effort)
        return {}

    def _assemble(self, coef: dict, core: tuple, effort: Effort) -> Optional[tuple]:
        n = self.predicted_length(coef, core)
        if not effort.affordable(2 * n):
            return None  # a plan this long does not fit the remaining budget
        effort.charge(n, "assembling plans")
        parts = []
        for b in sorted(coef):
            parts.extend(power(self.gens[b].word, coef[b], self.F))
        parts.extend(core)
        return purge(tuple(parts), self.F)

    # ------------------------------------------------------------- stages
    def _core_words(self, M: Motion, G: int, eps: float, paper_core, effort: Effort) -> list:
        A, F = self.A, self.F
        B = self.bwd(G, effort)
        if self.regime in ("exact_lattice", "exact_heading"):
            step = float(A.smallest_rotation) * math.pi
            aL = float(A.table.word_motion(F, A.transit_paths[G]).angle)
            h = aL + round((M.angle - aL) / step) * step
            cores = self.cores.exact_heading(B, M, h, n_cores=CORE_POOL * N_CORES, effort=effort)
        else:
            cores = self.cores.dense(B, M, 0.5 * eps, n_cores=CORE_POOL * N_CORES, effort=effort)
        words, seen = [], set()
        for _, ia, ib in cores:  # the first N_CORES distinct core words, best first
            effort.charge(int(self.fwd.depth[ia] + B.depth[ib]), "cores")
            w = purge(concat(self.fwd.word(ia), inverse(B.word(ib), G)), F)
            if w not in seen:
                seen.add(w)
                words.append(w)
                if len(words) == N_CORES:
                    break
        if paper_core is not None:
            words.append(paper_core)
        if self.regime == "dense":  # cheap cores of any heading, fixed by rotation loops
            words.append(A.transit_paths[G])
            words.extend(self.cores.short(B, F, G))
        return words

    def _score_cores(self, words: list, M: Motion, eps: float, effort: Effort) -> list:
        """``(core, its motion, translation still needed)`` per distinct core
        (dense: with its heading fixed by rotation loops first)."""
        F = self.F
        seen, scored = set(), []
        for cw in words:
            if cw in seen:
                continue
            seen.add(cw)
            mc = self._motion(cw, effort)
            if self.regime == "dense":
                rw = self.rotations(effort).word(float(wrap_angle_np(M.angle - mc.angle)),
                                                 0.45 * eps, effort)
                if rw is None:
                    continue
                if rw[0]:
                    cw = purge(concat(rw[0], cw), F)
                    mc = self._motion(cw, effort)
            # translation needed before the core: E_T o E_core = M (E_T a translation)
            scored.append((cw, mc, M.z - mc.z))
        return scored

    def _translations(self, scored: list, M: Motion, eps: float, effort: Effort) -> list:
        """``(estimated tumbles, loop counts, core, translation)`` candidates."""
        results = []
        if self.regime == "exact_lattice":
            for cw, mc, t in scored:
                k = closest_lattice_point(self.lattice.basis_vectors, (t.real, t.imag))
                dec = self.lattice.decompose(k)
                if dec is not None:
                    results.append((dec[1] + len(cw), dec[0], cw, t))
        elif not self.gens:
            results = [(len(cw), {}, cw, t) for cw, mc, t in scored]
        else:  # cheap ranking by the coarse estimate, fine stage for the best few
            prelim = sorted(scored, key=lambda s: len(s[0]) + self.rho * abs(s[2]))[:4]
            tol = 0.9 * eps
            for cw, mc, t in prelim:
                coef, cost, err = self.dense_loops.decompose(t, tol, effort)
                miss = 0.0 if err <= tol else 1e9 * err / self.scale
                results.append((cost + len(cw) + miss, coef, cw, t))
        return results

    def plan(self, M: Motion, G: int, eps: float, paper_core: Optional[tuple] = None,
             effort: Optional[Effort] = None) -> Optional[ShortResult]:
        """Shortest plan found for target motion ``M`` (start frame) ending on
        ``G`` within ``eps`` (else the most accurate); ``None`` if no core
        could be matched.  When ``effort`` runs out the best plan assembled so
        far is returned with ``exhausted`` set (its ``word`` None if none was)."""
        effort = Effort.unlimited() if effort is None else effort
        best, exhausted = None, None
        try:
            scored = self._score_cores(self._core_words(M, G, eps, paper_core, effort), M, eps,
                                       effort)
            results = sorted(self._translations(scored, M, eps, effort), key=lambda r: r[0])
            n_eval = min(N_EVALUATED, len(results))
            while n_eval < len(results) and results[n_eval][0] == results[n_eval - 1][0] and \
                    self.predicted_length(results[n_eval][1], results[n_eval][2]) <= TIE_EVAL_CAP:
                n_eval += 1
            for _, coef, cw, t in results[:n_eval]:
                word = self._assemble(coef, cw, effort)
                if word is None:  # too long for the budget: keep what fits as a fallback
                    exhausted = exhausted or (f"assembling a plan of "
                                              f"{self.predicted_length(coef, cw)} tumbles")
                    word = self._assemble(self._affordable(t, cw, effort), cw, effort)
                    if word is None:
                        continue
                m = self._motion(word, effort)
                dth = abs(float(wrap_angle_np(m.angle - M.angle)))
                dz = abs(m.z - M.z)
                err = max(dth, dz)
                key = (err > eps, len(word) if err <= eps else err)
                if best is None or key < best[0]:
                    best = (key, ShortResult(word=word, motion=m, error=err, orientation_residual=dth,
                                             position_residual=dz, core_length=len(cw),
                                             translation_length=len(word) - len(cw)))
        except BudgetExhausted as exc:
            exhausted = exc.stage
        if best is None:
            return None if exhausted is None else ShortResult(None, Motion(0.0, 0j), math.inf,
                                                              math.inf, math.inf, 0, 0, exhausted)
        best[1].exhausted = exhausted
        return best[1]

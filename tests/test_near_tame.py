"""Issue 21: near-tame parts.  A part known to ``tau_v`` whose coordinates carry
noise below it IS, at that tolerance, the ideal solid: it has the ideal
solid's faces (numbers and frames) and gets its plan, or one as short,
replayed within eps on the noisy part itself -- on its faces at tau_v, on its
hull as given (rocking over the creases the noise left), and as bare points
rolled in 3-D.

Since 3e4015b (the near-tame analysis) the faces were taken at a fixed 1e-9 x
the part's size whatever ``tau_v``: 1e-9 m of noise on a unit cube splits
some square into two triangles for 123 of 200 seeds (here another face 0,
framed along the diagonal), so the issue's goal was another configuration of another part
-- 'not_solvable', 54 tumbles, residual 0.4483 m.  Where the faces survived,
cores tied in the search were ranked by the noise (ring-ordered cube, seed
3: 10 tumbles, the ideal cube 8).  The one test of 3e4015b used one seed
whose six squares survive.
"""
from __future__ import annotations

import math
import warnings

import jax


import numpy as np  # noqa: E402
import pytest  # noqa: E402

from kernels.errors import PartWarning  # noqa: E402
from kernels.polyhedron import make_polyhedron  # noqa: E402
from planning.tumbling.planner import analyze_polyhedron, plan_tumble  # noqa: E402
from tests.polyhedra import check_plan, noisy, roll_on_vertices  # noqa: E402

pytestmark = pytest.mark.float64  # check_plan calls the kernel on float64 arrays

S3 = math.sqrt(3)
EPS = 1e-6
NOISE = 1e-9
#: Unit solids (metres) whose defect angles are rational and whose lattice is
#: discrete: the issue's cube (x varying fastest: its seed-0 noise splits two
#: squares), the cube with its corners in ring order (seed 3: the tie order),
#: the regular tetrahedron and octahedron (triangles: noise cannot split them)
#: and a near-tame prism (equilateral triangle of side 1, height sqrt(3)/2).
SOLIDS = {
    "cube": [[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)],
    "cube_ring": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1],
                  [0, 1, 1]],
    "tetrahedron": [[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]],
    "octahedron": [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]],
    "prism": [[0, 0, 0], [1, 0, 0], [0.5, S3 / 2, 0], [0, 0, S3 / 2], [1, 0, S3 / 2],
              [0.5, S3 / 2, S3 / 2]],
}
#: The goal: the issue's for the cubes, else where a fixed walk of the ideal
#: solid from face 0 ends (so the ideal solid reaches it exactly).
GOAL_WALKS = {
    "tetrahedron": [2, 1, 0, 2, 1, 0, 2, 3, 1, 2],
    "octahedron": [2, 3, 1, 0, 2, 3, 1, 5, 4, 6],
    "prism": [1, 4, 2, 0, 1, 2, 0, 3, 2, 1],
}
#: Noise seeds per solid: the first is the one that failed (the issue's seed 0;
#: seed 3 of the ring-ordered cube; seed 0 of the prism splits a rectangle).
SEEDS = {"cube": (0, 1, 2), "cube_ring": (3, 4), "tetrahedron": (0,), "octahedron": (0,),
         "prism": (0, 1)}


def _goal(name):
    V = np.asarray(SOLIDS[name], dtype=float)
    if name.startswith("cube"):
        return (-3.0, 1.0, 0.0, 0)
    A = analyze_polyhedron(V)
    m = A.table.word_motion(0, GOAL_WALKS[name])
    return (m.z.real, m.z.imag, math.remainder(m.angle, 2 * math.pi), GOAL_WALKS[name][-1])


@pytest.mark.slow
@pytest.mark.parametrize("tau_v", [1e-8, 1e-6])
@pytest.mark.parametrize("name", list(SOLIDS))
def test_near_tame_solid_gets_the_ideal_solids_plan(name, tau_v):
    """Every seed: solved, no longer than the ideal solid's plan, the kernel's
    replay on the part as planned within eps, and the bare noisy points rolled
    through the tumbles landing the goal face within eps."""
    V = np.asarray(SOLIDS[name], dtype=float)
    goal = _goal(name)
    ideal = plan_tumble(V, goal, eps=EPS, tau_v=tau_v)
    assert ideal.verdict == "solved" and ideal.reachable_class == "discrete", ideal.reason
    face = make_polyhedron(V).faces[goal[3]]
    for seed in SEEDS[name]:
        Vn = noisy(V, NOISE, seed)
        plan = plan_tumble(Vn, goal, eps=EPS, tau_v=tau_v)
        assert plan.verdict == "solved", (seed, plan.n_tumbles, plan.reason)
        assert plan.n_tumbles <= ideal.n_tumbles, (seed, plan.faces, ideal.faces)
        assert plan.reachable_class == "discrete"
        assert check_plan(plan, Vn) <= EPS
        err, touching = roll_on_vertices(plan, Vn)
        assert err <= EPS and tuple(touching) == face, (seed, err, touching, face)


def test_the_issues_cube_has_the_cubes_faces_at_its_tolerance():
    """The cause: 1e-9 m of noise splits two of the cube's squares at the
    default merge tolerance (8 faces; face 0 a triangle framed along the
    diagonal, so the goal was another configuration); at tau_v the part has
    the cube's six faces, numbered and framed as the cube's, for every seed."""
    V = np.asarray(SOLIDS["cube"], dtype=float)
    ideal = make_polyhedron(V)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PartWarning)
        assert make_polyhedron(noisy(V, NOISE, 0)).n_faces == 8
    for seed in range(8):
        for tau_v in (1e-8, 1e-6):
            P = make_polyhedron(noisy(V, NOISE, seed), tau_v=tau_v)
            assert P.face_cycles == ideal.face_cycles, (seed, tau_v)
            np.testing.assert_allclose(P.face_rotations, ideal.face_rotations, atol=1e-8)
    # tau_v = 0 keeps the faces of the coordinates as given; a tolerance that
    # is no number is refused naming it
    assert make_polyhedron(noisy(V, NOISE, 2), tau_v=0.0).n_faces == 6
    with pytest.raises(ValueError, match="tau_v"):
        make_polyhedron(V, tau_v=-1e-9)


def test_the_issues_cube_through_the_command_line(tmp_path, capsys):
    """The user's view: a part file with the noisy vertices, ``nudge
    plan-tumble --tau-v 1e-8``: solved in the cube's 8 tumbles, no warning
    about nearly coplanar faces (at its tolerance there are none)."""
    from sweeps import plan_tumble as cli

    Vn = noisy(SOLIDS["cube"], NOISE, 0)
    part = tmp_path / "noisy_cube.yaml"
    part.write_text("name: noisy_cube\nkind: polyhedron\nvertices:\n"
                    + "".join(f"  - [{', '.join(repr(float(c)) for c in p)}]\n" for p in Vn))
    code = cli.main([str(part), "--goal=-3,1,0,0", "--start", "0,0,0,0", "--eps", "1e-6",
                     "--tau-v", "1e-8"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "tumble plan: solved" in out and "8 tumbles" in out, out
    assert "coplanar" not in err, err


def test_a_plan_that_misses_on_the_hull_as_given_is_never_solved():
    """A cube whose corner 3 stands 4 mm proud: its bottom is two triangles
    bent 4e-3 rad; at tau_v = 1 mm they are one face.  The 12-tumble plan lands
    to 4e-16 on the part at its tolerance, but rolled on the hull as given
    (rocking over the crease) it misses by 4e-6: not solved at eps = 1e-6,
    solved at 1e-5 -- and the bare points rolled in 3-D agree both times."""
    V = np.asarray(SOLIDS["cube"], dtype=float)
    V[3, 2] += 4e-3
    goal = (2.0, 0.0, 0.0, 0)
    tight = plan_tumble(V, goal, eps=1e-6, tau_v=1e-3)
    assert tight.verdict == "not_solvable" and tight.error <= 1e-6
    assert "not on its hull as given" in tight.reason and tight.bounds["error_as_given"] > 1e-6
    assert roll_on_vertices(tight, V)[0] > 1e-6
    check_plan(tight, V)
    loose = plan_tumble(V, goal, eps=1e-5, tau_v=1e-3)
    assert loose.verdict == "solved" and "on its hull as given" in loose.reason
    assert loose.bounds["error_as_given"] <= 1e-5 and roll_on_vertices(loose, V)[0] <= 1e-5
    check_plan(loose, V)


def test_a_tolerance_that_leaves_no_faces_is_refused_naming_tau_v():
    """At 1 cm the 10 cm example cube's faces all lie within 8 tau_v of each
    other's planes: one clear error naming tau_v, before any planning."""
    V = np.asarray(SOLIDS["cube"], dtype=float) * 0.1
    with pytest.raises(ValueError, match=r"^tau_v: at 0.01 m the part's faces are not determined"):
        make_polyhedron(V, tau_v=1e-2)
    with pytest.raises(ValueError, match=r"^tau_v: at 0.01 m"):
        plan_tumble(V, (0.2, 0.0, 0.0, 0), eps=1e-3, tau_v=1e-2)


def test_the_robustness_layer_reads_the_plans_faces():
    """Evaluation rebuilds the plan's part: with its faces at the plan's tau_v
    (with the faces as given, the issue's plan was read on another face list:
    evaluated, 0 of 64 samples succeeded, errors of 4 m)."""
    from robustness.replay import tumble_nominal

    Vn = noisy(SOLIDS["cube"], NOISE, 0)
    plan = plan_tumble(Vn, (-3.0, 1.0, 0.0, 0), eps=EPS, tau_v=1e-8)
    assert tumble_nominal(plan).face_cycles == make_polyhedron(Vn, tau_v=1e-8).face_cycles
    assert tumble_nominal(plan).n_faces == 6

"""The main job's tables against a stored reference: a refactor keeps them, and a
change of the numbers is deliberate (issue 39).

``python -m sweeps.run margins.yaml --set samples=32`` (the bundled study: 18
configurations x 4 tasks, the faithful model on support ``any``), run as the
command runs it.  Per configuration and task, the summary's counts (successes,
each failure mode) and the plans' step counts must equal the reference exactly;
the one-sided lower bound, error and slip quantiles and push lengths to 1e-6
relative (not bit for bit: another CPU's compiled code may round differently,
and a fresh machine must pass).

After a deliberate change, regenerate the reference and say why in the commit::

    python tests/test_reference_tables.py --update
"""
from __future__ import annotations

import json
import math
import pathlib
import sys
import tempfile

import pandas as pd
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
REFERENCE = pathlib.Path(__file__).resolve().parent / "data" / "margins_reference.json"
ARGS = ("margins.yaml", "--set", "samples=32", "--quiet", "--no-report", "--yes")
SUMMARY_COUNTS = ("n", "n_success", "n_none", "n_incomplete_reorientation", "n_wrong_edge",
                  "n_slip", "n_hull_changed", "n_position", "n_orientation", "n_left_workspace",
                  "n_toppled", "n_fence_strike")
SUMMARY_FLOATS = ("ci_low_one_sided", "err_pos_m_q50", "err_pos_m_max", "err_theta_abs_rad_max",
                  "slip_m_q90")
PLAN_COUNTS = ("n_steps",)
PLAN_FLOATS = ("total_distance_m",)
RTOL, ATOL = 1e-6, 1e-12


def fingerprint(out: pathlib.Path) -> dict:
    """``{"<config_id>/<task>": {column: value}}`` of a run folder's summary and plans."""
    rows = {}
    for table, counts, floats in (("summary", SUMMARY_COUNTS, SUMMARY_FLOATS),
                                  ("plans", PLAN_COUNTS, PLAN_FLOATS)):
        df = pd.read_parquet(out / table)
        for r in df.itertuples(index=False):
            row = rows.setdefault(f"{int(r.config_id)}/{r.task}", {})
            row.update({c: int(getattr(r, c)) for c in counts})
            row.update({c: float(getattr(r, c)) for c in floats})
    return rows


def run_study(out: pathlib.Path) -> None:
    from sweeps import run
    from tests.commandline import in_process

    r = in_process(run.main, *ARGS, "--out", out, cwd=ROOT)
    assert r.returncode == 0, r.stderr


def differences(got: dict, want: dict) -> list:
    """One line per cell that differs (counts exactly, floats to RTOL)."""
    lines = [f"{k}: missing" for k in sorted(set(want) - set(got))]
    lines += [f"{k}: not in the reference" for k in sorted(set(got) - set(want))]
    for k in sorted(set(got) & set(want)):
        for c, w in want[k].items():
            g = got[k].get(c)
            same = (g == w if isinstance(w, int) else
                    g is not None and (math.isclose(g, w, rel_tol=RTOL, abs_tol=ATOL)
                                       or (math.isnan(g) and math.isnan(w))))
            if not same:
                lines.append(f"{k} {c}: {g!r}, reference {w!r}")
    return lines


@pytest.mark.slow
def test_the_main_job_gives_the_reference_tables(tmp_path):
    run_study(tmp_path / "out")
    got = fingerprint(tmp_path / "out")
    want = json.loads(REFERENCE.read_text())
    assert len(want) == 18 * 4
    diff = differences(got, want)
    assert not diff, ("the main job's tables moved (a deliberate change: `python "
                      "tests/test_reference_tables.py --update`):\n" + "\n".join(diff[:20]))


def test_the_comparison_sees_a_moved_count_and_a_moved_float():
    want = {"0/a": {"n_success": 30, "err_pos_m_q50": 1.0e-4}}
    assert not differences({"0/a": {"n_success": 30, "err_pos_m_q50": 1.0e-4 * (1 + 1e-9)}}, want)
    assert len(differences({"0/a": {"n_success": 29, "err_pos_m_q50": 1.0e-4}}, want)) == 1
    assert len(differences({"0/a": {"n_success": 30, "err_pos_m_q50": 1.01e-4}}, want)) == 1
    assert differences({}, want) == ["0/a: missing"]


if __name__ == "__main__":
    if sys.argv[1:] != ["--update"]:
        sys.exit("usage: python tests/test_reference_tables.py --update")
    sys.path.insert(0, str(ROOT))
    with tempfile.TemporaryDirectory() as d:
        run_study(pathlib.Path(d) / "out")
        fp = fingerprint(pathlib.Path(d) / "out")
    REFERENCE.parent.mkdir(exist_ok=True)
    REFERENCE.write_text(json.dumps(fp, indent=1, sort_keys=True) + "\n")
    print(f"wrote {REFERENCE} ({len(fp)} rows)")

"""A bound the Monte Carlo exceeds is a finding read from the summary table's
columns (``bound_violated``), not matched in warning text, and it is reported
once per kind, not as a warning per task."""
import pytest
import pandas as pd

from tests.test_sweep import TINY


@pytest.mark.slow
def test_a_bound_violation_is_a_finding_read_from_the_summary(tmp_path, monkeypatch, capsys):
    from robustness import Bound, summary
    from sweeps import run

    monkeypatch.delenv("NUDGE_DEBUG", raising=False)
    monkeypatch.setattr(summary, "analytic_bound",
                        lambda plan, sampler, kind: Bound(1e-12, 0.0, 1e-12))
    p = tmp_path / "tiny.yaml"
    p.write_text(TINY.replace("samples: 24", "samples: 8"))
    code = run.main([str(p), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    s = pd.read_parquet(tmp_path / "out" / "summary")
    assert code == 0 and s["bound_violated"].all() and len(s) == 4
    lines = [ln for ln in err.splitlines() if ln.startswith("finding:")]
    assert len(lines) == 1, err
    assert lines[0].startswith("finding: bound violated in 4 (configuration, task) pair(s), e.g. "
                               "task 'a': the Monte-Carlo maximum")
    assert "bound 1e-12 m / 1e-12 rad" in lines[0]
    assert "BOUND VIOLATED" not in err and "warning:" not in err


def test_no_finding_without_a_violation(tmp_path, capsys):
    from sweeps import run

    p = tmp_path / "tiny.yaml"
    p.write_text(TINY.replace("samples: 24", "samples: 8"))
    assert run.main([str(p), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    assert "finding:" not in capsys.readouterr().err
    assert not pd.read_parquet(tmp_path / "out" / "summary")["bound_violated"].fillna(False).any()


def test_the_paper_bound_finding_says_what_its_figure_is():
    """tolerances.yaml's finding printed the paper's bound as "1.1494e-113 m /
    3.70947e+10 rad" with nothing to say that this is the printed expression in
    metres, not a bug: the finding's kind says so."""
    from sweeps.work import findings

    row = dict(task="goal000", bound_violated=False, paper_bound_violated=True,
               emp_max_pos_in_model_m=7.63e-5, emp_max_theta_in_model_rad=2.76e-4,
               n_in_bound_model=100, bound_position_m=2e-4, bound_theta_rad=6e-4,
               paper_bound_position_m=1.1494e-113, paper_bound_theta_rad=3.70947e10)
    (kind, line), = findings(row)
    assert kind.startswith("paper bound violated (") and "evaluated in metres" in kind
    assert "depends on the unit of length" in kind
    assert "bound 1.1494e-113 m / 3.70947e+10 rad" in line

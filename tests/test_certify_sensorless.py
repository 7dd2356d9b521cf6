"""Sensorless tasks (issue 40) in certify configs and studies, through the
command a user types: ``start: {heading: any, region: [...]}`` planned with
:func:`planning.plan_sensorless`, its Monte Carlo drawing the start uniformly
over the heading interval and the region, and a certificate that says so; bad
input refused in one line (exit 2) before any work; known-start tables unchanged."""
import hashlib
import math
import pathlib

import numpy as np
import pandas as pd
import pytest

from tests.commandline import nudge_here

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"

KNOWN = f"""part: {EXAMPLES / 'biplus_stable.yaml'}
tolerances: {{tau_v: 2.0e-5, tau_com: 1.0e-4}}
friction: {{mu_f: [0.3, 0.8], support: any}}
execution: {{start_xy: 5.0e-4, start_theta: 0.01, fence_angle: 0.002, distance_abs: 1.0e-4}}
eps: {{pos_eps_m: 0.003, theta_eps_rad: 0.05}}
n_samples: 16
seed: 3
tasks:
  - {{name: turn, start: [0, 0, 0], goal: [0.10, 0.05, 60deg]}}
"""

#: digest of the known-start task's samples (final poses rounded to 1e-12, success,
#: failure mode, start offsets) as the code before sensorless tasks wrote them
KNOWN_DIGEST = "326088ff236a4a41ebe03a1762b7198ca637c75ea7b8ef77a33704eab2cc0841"


def _digest(samples: pd.DataFrame) -> str:
    s = samples.sort_values("sample_id")
    h = hashlib.sha256()
    for c in ("final_x_m", "final_y_m", "final_theta_rad", "start_dx_m", "start_dy_m",
              "start_dtheta_rad"):
        h.update(np.round(s[c].to_numpy(np.float64), 12).tobytes())
    h.update(s["success"].to_numpy(bool).tobytes())
    h.update("|".join(s["failure_mode"].astype(str)).encode())
    return h.hexdigest()


@pytest.mark.slow
def test_known_start_tables_unchanged(tmp_path):
    p = tmp_path / "known.yaml"
    p.write_text(KNOWN)
    out = tmp_path / "o"
    r = nudge_here("certify", p, "--out", out, "--quiet")
    assert r.returncode in (0, 1), r.stderr
    d = _digest(pd.read_parquet(out / "samples"))
    assert d == KNOWN_DIGEST, d

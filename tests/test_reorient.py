"""kernels.reorient: the monotonicity the model-based reorient distances rely
on, and the sticking limit of slip-aware plans, against the quasi-static
simulation (kernels.quasistatic) and the replay at the model's rate."""
from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from kernels import polygon as pg
from kernels import reorient as ro
from kernels.push import replay_push
from kernels.quasistatic import contact_rates, simulate_push

pytestmark = pytest.mark.float64  # calls kernels on float64 arrays directly

_sim = jax.jit(jax.vmap(lambda b, p, d, s, c, mu: simulate_push(pg.polygon_geometry(b), p, d, s, c, mu)))
_replay = jax.jit(jax.vmap(lambda b, p, d, s, c: replay_push(pg.polygon_geometry(b), p, d, s, rate_c=c)))


def test_rates_are_monotone_in_c_and_slip_only_speeds_up():
    """Claims 1 and 2 of kernels.reorient: the sticking rate falls as c grows,
    and every fence friction turns the part at least as fast as sticking."""
    rng = np.random.default_rng(0)
    rho = rng.uniform(0.005, 0.05, 4000)
    beta = rng.uniform(1e-3, math.pi / 2, 4000)
    c = rng.uniform(0.001, 0.05, 4000)
    a, b = -rho * np.cos(beta), rho * np.sin(beta) * rng.choice([-1, 1], 4000)
    w_stick = np.abs(np.asarray(contact_rates(a, b, c * c, np.inf)[0]))
    np.testing.assert_allclose(w_stick, ro.sticking_rate(rho, c, beta), rtol=1e-12)
    for mu in (0.0, 0.1, 0.5, 2.0):
        w = np.abs(np.asarray(contact_rates(a, b, c * c, mu)[0]))
        assert np.all(w >= w_stick * (1 - 1e-12))
        assert np.all(np.sign(np.asarray(contact_rates(a, b, c * c, mu)[0])) == np.sign(b))
    bigger = np.abs(np.asarray(contact_rates(a, b, (1.3 * c) ** 2, np.inf)[0]))
    assert np.all(bigger < w_stick)


def _cases(rng, count):
    """Random parts (rectangles and triangles) with a reorient push onto a stable edge."""
    out = []
    while len(out) < count:
        w, h = rng.uniform(0.01, 0.04, 2)
        body = np.array([[-w, -h], [w, -h], [w, h], [-w, h]]) + rng.uniform(-0.3, 0.3, 2) * [w, h]
        geom = pg.polygon_geometry(jnp.asarray(body))
        e = int(rng.integers(4))
        sense = int(rng.integers(2))
        if not bool(geom.stable[e]):
            continue
        mx = float(pg.max_reorient_angle(geom, e, sense))
        alpha = rng.uniform(0.2, 0.9) * mx
        out.append((body, geom, e, sense, alpha))
    return out


def _start(geom, e, sense, alpha):
    """Pose and push direction (fence moving +y) of a reorient by alpha onto edge e."""
    th_final = -0.5 * math.pi - float(geom.nu[e])
    th0 = th_final + (alpha if sense == pg.CW else -alpha)
    return np.array([0.0, 0.0, th0]), np.array([0.0, 1.0]), th_final


@pytest.mark.slow
def test_model_distance_completes_for_every_c_and_friction():
    """Claim 3: the model distance at c_hi completes the rotation in the
    quasi-static simulation for every c up to c_hi and every fence friction;
    0.99 of it does not at c_hi when the fence sticks (it is the shortest)."""
    rng = np.random.default_rng(1)
    rows = []
    for body, geom, e, sense, alpha in _cases(rng, 12):
        pivot = int(pg.pivot_vertex(4, e, sense))
        rho = float(np.hypot(*body[pivot]))
        beta2 = float(pg.alignment_angle(geom, e, sense))
        radius = float(np.max(np.hypot(*body.T)))
        c_hi = rng.uniform(0.3, 0.9) * radius
        s = pg.peshkin_length_np(ro.model_gain(c_hi, rho), beta2 - alpha, beta2)
        assert s < pg.peshkin_length_np(pg.peshkin_gain(radius, rho), beta2 - alpha, beta2)
        pose, d, th_final = _start(geom, e, sense, alpha)
        for c in (0.2 * c_hi, 0.6 * c_hi, c_hi):
            for mu in (0.0, 0.3, np.inf):
                rows.append((body, pose, d, 1.001 * s, c, mu, e, True))
        rows.append((body, pose, d, 0.99 * s, c_hi, np.inf, e, False))
    body, pose, d, s, c, mu, e, done = (np.array(x) for x in zip(*rows))
    out = _sim(jnp.asarray(body), jnp.asarray(pose), jnp.asarray(d), jnp.asarray(s), jnp.asarray(c),
               jnp.asarray(mu))
    edge = np.asarray(out.edge)
    assert np.all((edge == e)[done]), edge[done]
    assert np.all((edge == -1)[~done]), edge[~done]
    # the replay at the model's rate agrees: complete at 1.001 s, short at 0.99 s (c = c_hi rows)
    last = ~done
    rep = _replay(jnp.asarray(body[last]), jnp.asarray(pose[last]), jnp.asarray(d[last]),
                  jnp.asarray(s[last]), jnp.asarray(c[last]))
    assert not np.any(np.asarray(rep.complete))
    rep = _replay(jnp.asarray(body[last]), jnp.asarray(pose[last]), jnp.asarray(d[last]),
                  jnp.asarray(s[last] / 0.99 * 1.001), jnp.asarray(c[last]))
    assert np.all(np.asarray(rep.complete))


def test_friction_needed_closed_form():
    """|tau| of kernels.quasistatic, its maximum over an interval (unimodal peak)."""
    rng = np.random.default_rng(2)
    for _ in range(200):
        rho, c = rng.uniform(0.005, 0.05), rng.uniform(0.002, 0.05)
        beta = rng.uniform(1e-3, math.pi / 2 - 1e-3)
        a, b = -rho * math.cos(beta), rho * math.sin(beta)
        tau = -a * b / (c * c + a * a)
        assert ro.friction_needed(rho, c, beta) == pytest.approx(abs(tau), rel=1e-12)
        b1 = rng.uniform(1e-3, 1.5)
        b2 = rng.uniform(b1, math.pi / 2)
        grid = np.linspace(b1, b2, 20001)
        assert ro.max_friction_needed(rho, c, b1, b2) == pytest.approx(
            float(np.max(ro.friction_needed(rho, c, grid))), rel=1e-6)


def test_sticking_angle_limit_against_the_simulation():
    """A push of the sticking limit does not slip for c >= c_lo at mu; a push
    10 % larger (when the limit is below beta2) slips at c_lo."""
    rng = np.random.default_rng(3)
    rows, seen = [], {"limited": 0, "free": 0, "none": 0}
    for body, geom, e, sense, _ in _cases(rng, 40):
        pivot = int(pg.pivot_vertex(4, e, sense))
        rho = float(np.hypot(*body[pivot]))
        beta2 = float(pg.alignment_angle(geom, e, sense))
        mx = float(pg.max_reorient_angle(geom, e, sense))
        c_lo = rng.uniform(0.2, 0.8) * float(np.max(np.hypot(*body.T)))
        mu = rng.uniform(0.2, 1.0)
        lim = ro.sticking_angle_limit(rho, c_lo, beta2, mu)
        assert 0.0 <= lim <= beta2
        if lim == 0.0:
            seen["none"] += 1
            assert ro.friction_needed(rho, c_lo, beta2) > mu
            continue
        alpha = min(lim, 0.95 * mx) * (1 - 1e-6)
        assert ro.max_friction_needed(rho, c_lo, beta2 - alpha, beta2) <= mu * (1 + 1e-9)
        pose, d, _ = _start(geom, e, sense, alpha)
        s = 1.2 * pg.peshkin_length_np(pg.peshkin_gain(float(np.max(np.hypot(*body.T))), rho),
                                       beta2 - alpha, beta2)
        for c in (c_lo, 1.5 * c_lo):
            rows.append((body, pose, d, s, c, mu, False))
        if lim < 0.9 * mx:
            seen["limited"] += 1
            pose, d, _ = _start(geom, e, sense, min(1.1 * lim, 0.99 * mx))
            rows.append((body, pose, d, s * 2, c_lo, mu, True))
        else:
            seen["free"] += 1
    body, pose, d, s, c, mu, slips = (np.array(x) for x in zip(*rows))
    out = _sim(jnp.asarray(body), jnp.asarray(pose), jnp.asarray(d), jnp.asarray(s), jnp.asarray(c),
               jnp.asarray(mu))
    slip = np.asarray(out.slip)
    assert np.all(slip[~slips] == 0.0), slip[~slips]
    assert np.all(slip[slips] > 0.0), slip[slips]
    assert min(seen.values()) > 0, seen

"""The flange predictors (loadarm.guidance.predict) against independent routes, and their calibration on the
hold-out records (loadarm.studies.prediction)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from loadarm.guidance import predict as pr

from .conftest import ROOT
from .hypo import examples


def _stable_phi(roots: list[float]) -> np.ndarray:
    """AR coefficients (lag 1 first) of the polynomial with these real roots inside the unit circle."""
    poly = np.poly(roots)                                  # z^p + c1 z^(p-1) + ...: phi_k = -c_k
    return -poly[1:]


def _simulate(phi: np.ndarray, n: int, sigma: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    p = len(phi)
    x = np.zeros(n + 500)
    e = rng.normal(0, sigma, n + 500)
    for t in range(p, n + 500):
        x[t] = phi @ x[t - p: t][::-1] + e[t]
    return x[500:]


@settings(max_examples=examples(40), deadline=None)
@given(roots=st.lists(st.floats(-0.95, 0.95), min_size=1, max_size=4),
       hist=st.lists(st.floats(-2, 2), min_size=4, max_size=4), steps=st.integers(1, 30))
def test_the_forecast_is_the_companion_matrix_s(roots, hist, steps):
    """Mean and variance of the AR recursion and its psi-weights against the state-space route: the companion
    matrix A to the power h (mean e1' A^h x) and the variance sigma^2 sum_{j<h} (e1' A^j e1)^2, to 1e-9."""
    phi = _stable_phi(roots)
    p = len(phi)
    model = pr.ArModel(np.tile(phi, (3, 1)), np.array([1.0, 0.5, 2.0]), np.ones(3), np.zeros(3), "test")
    history = np.tile(np.array(hist[:p])[:, None], (1, 3))
    mean, sd = pr.ar_forecast(model, history, steps)
    a = np.zeros((p, p))
    a[0] = phi
    a[1:, :-1] = np.eye(p - 1)
    x = history[::-1, 0].copy()                            # newest first
    power, var = np.eye(p), 0.0
    for h in range(steps):
        var += power[0, 0] ** 2
        power = a @ power
        assert mean[h, 0] == pytest.approx((power @ x)[0], abs=1e-9)
        assert sd[h] == pytest.approx(np.sqrt(var * model.sigma2), rel=1e-9)
    kept = pr.psi_variance(model.phi, steps + 7)           # the live predictor's, kept between forecasts of a fit
    mean_k, sd_k = pr.ar_forecast(model, history, steps, psi2=kept)
    assert np.array_equal(mean_k, mean) and np.array_equal(sd_k, sd)


def test_the_online_fit_recovers_a_known_autoregression():
    """Least squares on 20 000 samples of an AR(2) (phi 1.5, -0.7): each coefficient within 4 standard errors
    (about 0.005 each at this length), the innovation variance within 3 %."""
    phi = np.array([1.5, -0.7])
    x = _simulate(phi, 20000, 0.1, seed=3)
    track = np.column_stack([x, 0.5 * x, x[::-1]])
    m = pr.fit_ar(track, order=2)
    assert np.allclose(m.phi, phi, atol=0.02)
    assert m.sigma2 == pytest.approx([0.01, 0.0025, 0.01], rel=0.03)
    with pytest.raises(ValueError, match="more than 4 samples"):
        pr.fit_ar(track[:4], order=2)


def test_the_fit_over_several_records_is_the_stacked_least_squares():
    """The model route's fit over several records (normal equations summed, each record about its own mean)
    against NumPy's least squares of the stacked rows (ridge off), to 1e-9."""
    rng = np.random.default_rng(0)
    recs = [np.cumsum(rng.normal(size=(300, 3)), axis=0) * 0.01, rng.normal(size=(200, 3)) + 1.0]
    m = pr.fit_ar(recs, order=4, ridge=0.0, route="model AR")
    for ax in range(3):
        rows, targets = [], []
        for r in recs:
            y = r[:, ax] - r[:, ax].mean()
            rows += [y[t - 4: t][::-1] for t in range(4, len(y))]
            targets += list(y[4:])
        want = np.linalg.lstsq(np.array(rows), np.array(targets), rcond=None)[0]
        assert m.phi[ax] == pytest.approx(want, abs=1e-9)
    assert m.route == "model AR" and m.mean is None


def test_the_calibration_is_the_conformal_order_statistic_and_claims_nothing_early():
    """Normalised errors realised one by one: before ``min_errors`` no horizon is claimed (the forecast is all
    no-prediction, nan); then each horizon's upper edge is the ceil(0.975 (n + 1))-th smallest of its signed
    errors and its lower edge the same of their negatives, found by sorting; the window keeps the last
    ``memory``."""
    cal = pr.Calibrator(3, memory=50, min_errors=20)
    rng = np.random.default_rng(1)
    truth = rng.normal(size=(200, 3))
    zs = {j: [] for j in range(3)}
    for t in range(100):
        cal.observe(t, truth[t])
        q = cal.quantiles()
        if t < 20:
            assert pr.claimed_steps(q) == 0
            lo, hi = pr.interval(np.zeros((3, 3)), np.ones((3, 3)), q, pr.claimed_steps(q))
            assert np.all(np.isnan(lo)) and np.all(np.isnan(hi))
        cal.remember(t, np.zeros((3, 3)), np.full((3, 3), 2.0))
        for j in range(3):
            if t - j - 1 >= 0:
                zs[j].append(truth[t] / 2.0)
    q = cal.quantiles()
    assert q.shape == (3, 3, 2)
    for j in range(3):
        last = np.array(zs[j][-50:])                                       # the window's 50 forecasts
        k = math.ceil(0.975 * 51) - 1
        assert np.array_equal(q[j, :, 1], np.sort(last, axis=0)[k])
        assert np.array_equal(q[j, :, 0], np.sort(-last, axis=0)[k])
        lo, hi = pr.interval(np.zeros((1, 3)), np.full((1, 3), 2.0), q[j:j + 1], 1)
        assert np.array_equal(hi[0], 2.0 * q[j, :, 1]) and np.array_equal(lo[0], -2.0 * q[j, :, 0])
    assert pr.claimed_steps(q) == 3
    assert np.array_equal(cal.quantiles([2, 0]), q[[2, 0]])
    first = cal.refreshed(2)                                            # the real-time form: two rows a call
    assert np.array_equal(first[:2], q[:2]) and np.all(np.isnan(first[2]))
    assert np.array_equal(cal.refreshed(2), q)                          # row 2, then row 0 again: all of them
    with pytest.raises(ValueError, match="level"):
        pr.Calibrator(3, level=1.2)


def test_a_calibrated_gaussian_predictor_covers_95_percent():
    """Errors that are exactly the model's Gaussian: the calibrated interval covers 95 % (within 1 %: 30 000
    forecasts, the binomial standard error 0.13 %)."""
    cal = pr.Calibrator(1, memory=600, min_errors=60)
    rng = np.random.default_rng(2)
    hits = n = 0
    for t in range(10000):
        x = rng.normal(size=3) * [1.0, 2.0, 0.5]
        cal.observe(t, x)
        q = cal.quantiles()
        if pr.claimed_steps(q):
            lo, hi = pr.interval(np.zeros((1, 3)), np.array([[1.0, 2.0, 0.5]]), q, 1)
            pending = (lo, hi)
        else:
            pending = None
        if t and prev is not None:
            hits += int(np.sum((x >= prev[0][0]) & (x <= prev[1][0])))
            n += 3
        prev = pending
        cal.remember(t, np.zeros((1, 3)), np.array([[1.0, 2.0, 0.5]]))
    assert n > 29000 and hits / n == pytest.approx(0.95, abs=0.01)


def test_errors_that_lean_to_one_side_get_each_edge_s_own_tail():
    """Errors from a skewed law (a gamma's, mean removed: a long tail above, a short one below, as the hold-out
    records' errors off the berth lean): each side's tail is 2.5 % (within 0.6 %: 8000 forecasts on each of
    three axes, the binomial standard error 0.1 %, with the window's own sampling spread on top), where a calibration of the absolute error's 95 % quantile put about 4 %
    above and 1 % below (the finding this replaces: checked here on the same errors, so the test can fail)."""
    cal = pr.Calibrator(1, memory=600, min_errors=200)
    rng = np.random.default_rng(3)
    above = below = absolute_above = n = 0
    prev = None
    sd = np.ones((1, 3))
    for t in range(8200):
        x = rng.gamma(2.0, 1.0, size=3) - 2.0
        cal.observe(t, x)
        if prev is not None:
            q, zabs = prev
            above += int(np.sum(x > q[0, :, 1]))
            below += int(np.sum(x < -q[0, :, 0]))
            absolute_above += int(np.sum(x > zabs))
            n += 3
        q = cal.quantiles()
        if pr.claimed_steps(q):
            window = cal.z[0, :, : min(cal.count[0], cal.memory)]
            k = math.ceil(0.95 * (window.shape[1] + 1)) - 1
            prev = (q, np.sort(np.abs(window), axis=1)[:, k])
        cal.remember(t, np.zeros((1, 3)), sd)
    assert n > 23900
    assert above / n == pytest.approx(0.025, abs=0.006) and below / n == pytest.approx(0.025, abs=0.006)
    assert absolute_above / n > 0.04                                     # what the two-sided reading gave


@pytest.mark.slow
def test_the_hold_out_calibration_holds_and_the_docs_quote_it(tmp_path):
    """Both routes over the hold-out records (six states, two seeds each, two hours): the online AR's 95 %
    interval covers 93-97 % at every horizon up to 120 s on x and y (the horizon it claims), and beats the
    climatology at 30 s; the figure's numbers are the page's (docs/guidance.md)."""
    from loadarm.params.berth import load_berth
    from loadarm.ship.model import compile_ship
    from loadarm.studies.prediction import calibrate_predictors

    bf = load_berth(ROOT / "examples" / "berths" / "lng150k.toml")
    r = calibrate_predictors(compile_ship(bf), bf.environment)
    s = r.summary()
    assert s["online_claimed_s"] == pr.HORIZON == pr.CLAIMS["online AR"]
    assert s["model_claimed_s"] == pr.CLAIMS["model AR"]                # the live claim is the hold-out's
    assert s["online_skill_30s"] < 0.6
    page = " ".join((ROOT / "docs" / "guidance.md").read_text().split())
    for key in ("online_claimed_s", "model_claimed_s"):
        assert f"{s[key]:.0f} s" in page
    lo, hi = s["online_coverage_range"]
    assert f"{100 * lo:.1f}-{100 * hi:.1f} %" in page
    assert f"{s['online_skill_30s']:.2f} of the climatology's" in page
    on = r.routes["online AR"]
    n = int(on.claimed())
    below, above = on.below[:n, :2], on.above[:n, :2]                 # each side's tail, x and y
    assert f"in {100 * above[:, 0].mean():.1f} % of its claimed forecasts" in page
    assert f"at most {100 * above[:, 0].max():.1f} %) and its lower edge in {100 * below[:, 0].mean():.1f} %" in page
    assert (f"{100 * above[:, 1].mean():.1f} % and {100 * below[:, 1].mean():.1f} % (at most "
            f"{100 * max(above[:, 1].max(), below[:, 1].max()):.1f} %)") in page
    assert f"of an error to its side's edge at 5, 10 or 20 s was {s['online_gate_ratio']:.2f}" in page
    assert 2.0 < s["online_gate_ratio"] < 5.0
    assert s["online_tail_max"] == pytest.approx(max(below.max(), above.max()))
    assert s["online_tail_max"] <= 1.0 - pr.LEVEL + 0.01                    # at most the two-sided 5 %, or near
    from loadarm.present.docsgen import compare_figures, study_figures

    bad = compare_figures(ROOT / "docs" / "img", study_figures(tmp_path, ("prediction.png",), prediction=r))
    assert not bad, "stale figure (run `make docs`): " + "; ".join(bad)



def test_the_departure_test_measures_each_error_against_its_own_side_s_edge():
    """An error above the mean is measured against the upper edge's distance, one below against the lower's (a
    drift towards the narrow side is caught at the narrow edge, not the wide one: found by review), each at least
    half the wider (an edge inside the mean would count every error on its side); against a plain loop."""
    rng = np.random.default_rng(5)
    err = rng.normal(size=200)
    below, above = rng.uniform(-0.5, 2.0, 200), rng.uniform(-0.5, 2.0, 200)
    got = pr.gate_ratio(err, below, above)
    for e, b, a, g in zip(err, below, above, got):
        side = a if e >= 0 else b
        assert g == pytest.approx(abs(e) / max(side, 0.5 * max(a, b)), rel=1e-12)
    assert pr.gate_ratio(np.array([-1.0, 1.0]), np.array([0.5, 0.5]), np.array([2.0, 2.0])).tolist() == [1.0, 0.5]

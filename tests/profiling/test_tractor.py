"""Profile likelihood of the six tire parameters (thesis 3.2.3.1, ramp steer, 5 Hz, 10 s)."""

import json

import numpy as np
import pytest
from scipy.stats import chi2 as chi2_dist

import fmuid
from fmuid.data import spec_from_json
from fmuid.model.simulator import Simulator

from .tractor_data import TIRES, ramp_dataset, tire_spec

pytestmark = pytest.mark.slow


def fisher_interval_ends(fmu, experiment, sigma, estimates, threshold):
    """Quadratic (Fisher) CI ends in log10 space from central-difference sensitivities.

    Computed here from raw simulations, independently of the engine's Jacobian code.
    """
    sim = Simulator(fmu)
    t_in, u = experiment.input_samples("delta")
    mask = experiment.output_mask("gam_t")
    t_out = experiment.time[mask]
    names = list(estimates)

    def outputs(log_values):
        params = {n: 10.0**v for n, v in zip(names, log_values)}
        return sim.simulate(params, t_in, {"delta": u}, t_out, ["gam_t", "gam_i"]).ravel() / sigma

    z = np.log10([estimates[n] for n in names])
    cols = []
    for i in range(len(names)):
        h = 1e-5
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        cols.append((outputs(zp) - outputs(zm)) / (2 * h))
    jac = np.column_stack(cols)
    cov = np.linalg.inv(jac.T @ jac)
    half = np.sqrt(threshold * np.diag(cov))
    return {n: (z[i] - half[i], z[i] + half[i], half[i]) for i, n in enumerate(names)}


@pytest.fixture(scope="module")
def snr1000(tractor_fmu):
    data, sigma = ramp_dataset(tractor_fmu, snr=1000, seed=1)
    result = fmuid.profile(tractor_fmu, [data], tire_spec(sigma), workers=2)
    return data, sigma, result


def test_all_six_identifiable_at_snr_1000(snr1000):
    _, _, result = snr1000
    assert set(result.parameters) == set(TIRES)
    for name, p in result.parameters.items():
        assert p.status == "identifiable", name
        lo, hi = p.ci_simultaneous
        assert lo < p.estimate < hi
    assert result.thresholds["simultaneous"] == pytest.approx(chi2_dist.ppf(0.68, 6))


def test_profiles_near_parabolic_at_snr_1000(tractor_fmu, snr1000):
    data, sigma, result = snr1000
    estimates = result.fit.estimates
    quad = fisher_interval_ends(
        tractor_fmu, data, sigma, estimates, result.thresholds["simultaneous"]
    )
    for name, p in result.parameters.items():
        q_lo, q_hi, half = quad[name]
        lo, hi = np.log10(p.ci_simultaneous)
        # sig_ir, the least sensitive parameter (thesis 3.3.1.1), is visibly skewed even at
        # SNR 1000; brute-force re-fits confirm its ends (test below).
        tol = 0.15 if name == "sig_ir" else 0.05
        assert abs(lo - q_lo) <= tol * half, name
        assert abs(hi - q_hi) <= tol * half, name


def test_interval_ends_confirmed_by_brute_force_refits(tractor_fmu, snr1000):
    """Fixing a parameter at its CI end and re-fitting the rest from scratch gives the threshold."""
    data, sigma, result = snr1000
    for name in ("sig_ir", "C_atr"):
        for end in result.parameters[name].ci_simultaneous:
            others = {n: v for n, v in TIRES.items() if n != name}
            body = {
                "parameters": {
                    n: {"start": v, "lower": lo, "upper": hi} for n, (v, lo, hi) in others.items()
                },
                "fixed": {name: end},
                "inputs": ["delta"],
                "outputs": {"gam_t": {"sigma": sigma}, "gam_i": {"sigma": sigma}},
                "global_search": False,
            }
            refit = fmuid.fit(tractor_fmu, [data], spec_from_json(json.dumps(body)))
            rise = refit.chi2 - result.chi2
            assert rise == pytest.approx(result.thresholds["simultaneous"], rel=0.03), (name, end)


def test_thesis_table_3_3_magnitudes(snr1000):
    """Our intervals have the widths PottersWheel found (Table 3.3), within a factor of two."""
    thesis = {
        "C_atf": (218600, 220800),
        "C_atr": (481400, 489200),
        "C_air": (162700, 175900),
        "sig_tf": (0.486, 0.513),
        "sig_tr": (0.969, 1.010),
    }
    _, _, result = snr1000
    for name, (lo, hi) in thesis.items():
        ours = np.log10(result.parameters[name].ci_simultaneous)
        ratio = (ours[1] - ours[0]) / (np.log10(hi) - np.log10(lo))
        assert 0.5 < ratio < 2.0, (name, ratio)


def test_low_snr_gives_a_null_interval_end(tractor_fmu):
    data, sigma = ramp_dataset(tractor_fmu, snr=12.5, seed=1)
    result = fmuid.profile(tractor_fmu, [data], tire_spec(sigma), workers=2)
    ends = [e for p in result.parameters.values() for e in p.ci_simultaneous]
    assert any(e is None for e in ends)
    assert any(p.status == "practically_non_identifiable" for p in result.parameters.values())

import dataclasses
import math

from fmuid.demo.advice import StudyCase, advice_tables, study_verdict, trade_partners
from fmuid.demo.report import _cell
from fmuid.profiling.result import ProfilePoint
from plots.toy import CHI2_OPT, toy_profile_result


def _flat_k():
    """The toy result with k's profile flat (chi2 never rises) and m wandering wildly."""
    result = toy_profile_result()
    k = result.parameters["k"]
    points = tuple(
        ProfilePoint(p.value, CHI2_OPT + 0.01, {"m": 1.0 * 10 ** (5 * i)}, (), None)
        for i, p in enumerate(k.points)
        if p.error is None
    )
    flat = dataclasses.replace(k, points=points, ci_simultaneous=(None, None))
    return dataclasses.replace(result, parameters={**result.parameters, "k": flat})


def _tiny_step_k():
    """k's only point on its open side lies 1e-9 decades off the estimate (a 'slope' of 1e8)."""
    result = toy_profile_result()
    k = result.parameters["k"]
    near = ProfilePoint(k.estimate * 10**1e-9, CHI2_OPT + 5.0, {"m": 10.0**-0.1}, (), None)
    kept = tuple(p for p in k.points if p.value <= k.estimate) + (near,)
    short = dataclasses.replace(k, points=kept)
    return dataclasses.replace(result, parameters={**result.parameters, "k": short})


def _narrow_m():
    """The toy result with m's simultaneous CI 0.1 decades wide."""
    result = toy_profile_result()
    m = dataclasses.replace(result.parameters["m"], ci_simultaneous=(10**-0.05, 10**0.05))
    return dataclasses.replace(result, parameters={**result.parameters, "m": m})


def test_a_rising_open_side_gives_the_trade_off_slope():
    # the toy's m moves -0.5 decades per decade of k by construction (plots/toy.py)
    (partner,) = trade_partners(toy_profile_result(), "k")
    assert partner[0] == "m"
    assert math.isclose(partner[1], -0.5)


def test_no_slope_where_the_profile_is_flat_or_barely_moved():
    assert trade_partners(_flat_k(), "k") == []
    assert trade_partners(_tiny_step_k(), "k") == []


def test_one_compact_table_per_design():
    good, flat = toy_profile_result(), _flat_k()
    cases = [
        StudyCase("ramp", 1000.0, good),
        StudyCase("ramp", 25.0, flat),
        StudyCase("chirp", 1000.0, good),
        StudyCase("chirp", 25.0, _narrow_m()),
    ]
    tables = advice_tables(cases)
    assert [t.design for t in tables] == ["ramp", "chirp"]
    ramp = tables[0]
    assert ramp.header == ("parameter", "SNR 1000", "SNR 25", "narrowest at")
    rows = {r[0].text: [c.text for c in r[1:]] for r in ramp.rows}
    assert set(rows) == {"m", "k"}
    # m's 68 % simultaneous CI: 2 * 0.1 * sqrt(2.28) decades wide (plots/toy.py)
    assert rows["m"][0].startswith(f"{2 * 0.1 * math.sqrt(2.28):.2g} dec")
    assert rows["k"][1] == "PNI, open lower and upper"
    assert "decades per decade" not in " ".join(c for r in rows.values() for c in r)
    chirp = {r[0].text: [c.text for c in r[1:]] for r in tables[1].rows}
    assert chirp["m"][1] == "0.1 dec (narrowest)"
    assert chirp["m"][0] == rows["m"][0]  # a tie at SNR 1000: neither design is marked
    assert study_verdict(cases)[0] == "ramp: identifiable 1 of 2 at SNR 1000, 1 of 2 at SNR 25."


def test_datasets_table_says_open_for_a_null_end():
    assert _cell((1.0, None), "practically_non_identifiable") == "1 \u2013 open PNI"

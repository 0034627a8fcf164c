"""A profile's path as a table: every point of every profile, against the toy's closed form."""

import csv
import math

import numpy as np
import pytest

from plots.toy import CHI2_OPT, THRESHOLDS, toy_profile_result

pytest.importorskip("pandas")


def test_path_frame_holds_every_point_with_its_refit():
    result = toy_profile_result()
    frame = result.path_frame()
    assert list(frame.columns) == [
        "parameter",
        "value",
        "chi2",
        "delta_chi2",
        "inside",
        "m",
        "k",
        "at_bound",
        "error",
    ]
    assert len(frame) == sum(len(p.points) for p in result.parameters.values())
    sd = {"m": 0.1, "k": 0.2}
    for name, other in (("m", "k"), ("k", "m")):
        rows = frame[frame.parameter == name]
        dz = np.log10(rows.value / result.fit.estimates[name])
        ok = rows.error == ""
        # the toy's profiles are exact quadratics in log10: chi2 = opt + (dz / sd)^2
        assert rows.delta_chi2[ok].to_numpy() == pytest.approx((dz[ok] / sd[name]) ** 2)
        assert rows.chi2[ok].to_numpy() == pytest.approx(CHI2_OPT + (dz[ok] / sd[name]) ** 2)
        inside = (dz / sd[name]) ** 2 <= THRESHOLDS["simultaneous"]
        assert (rows.inside == (inside & ok)).all()
        assert (rows[name] == rows.value).all()
        expected_other = result.fit.estimates[other] * 10 ** (-0.5 * dz)
        assert rows[other].to_numpy() == pytest.approx(expected_other.to_numpy())
        assert rows.at_bound.iloc[0] == other and rows.error.iloc[-1] == "simulation failed"
        assert math.isnan(rows.chi2.iloc[-1]) and not rows.inside.iloc[-1]


def test_the_profile_report_links_the_path_as_csv(tmp_path):
    from fmuid.report import write_report

    result = toy_profile_result()
    index = write_report(result, tmp_path / "report")
    assert 'href="profile_path.csv"' in index.read_text(encoding="utf-8")
    with open(index.parent / "profile_path.csv", newline="") as stream:
        rows = list(csv.DictReader(stream))
    frame = result.path_frame()
    assert len(rows) == len(frame) and list(rows[0]) == list(frame.columns)
    for row, (_, expected) in zip(rows, frame.iterrows(), strict=True):
        assert row["parameter"] == expected.parameter and row["error"] == expected.error
        assert row["inside"] == ("true" if expected.inside else "false")
        if expected.error:
            assert row["chi2"] == ""  # NaN: an empty cell
        else:
            assert float(row["delta_chi2"]) == pytest.approx(expected.delta_chi2, rel=1e-9)
            assert float(row["k"]) == pytest.approx(expected.k, rel=1e-9)

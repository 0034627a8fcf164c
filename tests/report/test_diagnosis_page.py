import html
import re

from fmuid.report import write_report
from fmuid.report.page import fmt


class _Unexplained:
    """An 'unexplained' diagnosis with nested dicts wherever the JSON has them."""

    def to_dict(self):
        return {
            "mismatch": True,
            "effect": "unexplained",
            "description": "A mismatch no catalogue entry explains.",
            "evidence": [
                {
                    "test": "residual_whiteness",
                    "output": "x",
                    "experiment": "a.csv",
                    "p_value": 1e-8,
                    "statistic": 80.0,
                    "df": 20.0,
                }
            ],
            "location": {
                "outputs": ["x"],
                "experiments": ["a.csv"],
                "time_windows": [[1, 2]],
                "frequency_hz": [0.5, 1.0],
                "chi2_gain": {"a.csv/x": 12.0},
            },
            "candidates": [
                {
                    "effect": "output_bias",
                    "parameters": {"bias_x": 0.1},
                    "chi2": 90.0,
                    "p_value": 0.2,
                    "statistic": 1.0,
                    "p_adjusted": 0.5,
                    "stage": 1,
                }
            ],
            "indistinguishable": [
                {
                    "effect": "output_lag",
                    "parameters": {"tau_outputs": 0.1},
                    "chi2": 91.0,
                    "test": "equal_predictions",
                    "p_value": 1.0,
                    "intervals": {"tau_outputs": {"estimate": 0.1}},
                }
            ],
            "added_parameters": {},
            "absorbed": {},
            "generic_correction": {
                "model": "ARX(4, 6)",
                "chi2_before": 120.0,
                "chi2_after": 60.0,
                "noise_chi2": 55.0,
                "structure_fraction": 0.92,
                "outputs": {"x": {"chi2_before": 120.0}},
                "dynamics": {
                    "mode": {"frequency_hz": 0.8, "damping": 0.1},
                    "frequency_hz": [0.5, 1.0],
                    "band_output": "x",
                    "leads": None,
                },
            },
            "chi2_before": 120.0,
            "chi2_after": 120.0,
            "parameters": {"k": {"before": 4.4, "after": 4.4}},
            "units": {"k": "N/m", "x": "m"},
            "whiteness_before": {"a.csv/x": 1e-8},
            "whiteness_after": {"a.csv/x": 1e-8},
            "cost": {
                "simulations": 12,
                "seconds": 1.75,
                "stages": [
                    {"stage": "scan", "simulations": 10, "seconds": 1.25},
                    {"stage": "forward selection", "simulations": 2, "seconds": 0.5},
                ],
            },
        }


def test_no_python_literal_reaches_the_page_and_units_show(tmp_path):
    text = html.unescape(write_report(_Unexplained(), tmp_path).read_text())
    body = re.sub(r"<[^>]+>", " ", text.split("<body>")[1])
    assert "{'" not in body and "': " not in body
    assert body.index("Verdict") < body.index("Summary")
    assert re.search(r"k\s+N/m\s+4\.4\s+4\.4", body)
    assert "0.8 Hz, damping ratio 0.1" in body
    assert "tau_outputs = 0.1" in body and "bias_x = 0.1" in body
    assert re.search(r"scan\s+10\s+.+forward selection\s+2\s+.+total\s+12\s", body)


def test_fmt_writes_mappings_and_lists_as_text():
    assert fmt({"a": 1.0, "b": [1, None]}) == "a = 1; b = 1, \u2014"
    assert fmt({"a": {"b": 2.5}}) == "a = b = 2.5"


def _proposal():
    """A settling test as the diagnosis stores it (a step on input f, two outputs)."""
    import numpy as np

    from fmuid.experiment_design.discriminate import Discrimination
    from fmuid.experiment_design.signals import Trial

    time = np.linspace(0.0, 6.0, 61)
    trial = Trial("step", {"amplitude": 1.0, "time": 1.0}, 6.0, 10.0, ("x", "v"))
    lag = {"x": np.tanh(time), "v": np.cosh(time) ** -2}
    delay = {"x": np.tanh(time - 0.1), "v": np.cosh(time - 0.1) ** -2}
    found = Discrimination(
        trial,
        ("output_lag", "input_delay"),
        {"input_delay fitted to output_lag": 41.5, "output_lag fitted to input_delay": 38.25},
        time,
        {"output_lag": lag, "input_delay": delay},
        "f",
        24,
        {"x": 0.005, "v": 0.01},
    )
    return found


def test_a_settling_test_round_trips_through_json():
    import json

    from fmuid.experiment_design.discriminate import discrimination_from_dict

    doc = json.loads(json.dumps(_proposal().to_dict()))
    again = discrimination_from_dict(doc)
    assert again.to_dict() == doc
    assert again.expected_chi2 == 38.25
    assert again.trial.outputs == ("x", "v") and again.input_name == "f"


def test_the_settling_test_gets_its_table_and_figure(tmp_path):
    doc = _Unexplained().to_dict()
    doc.update(effect="output_lag", discriminating_experiment=_proposal().to_dict())

    class _Named:
        def to_dict(self):
            return doc

    text = html.unescape(write_report(_Named(), tmp_path).read_text())
    body = re.sub(r"<[^>]+>", " ", text.split("<body>")[1])
    assert "The test that tells output_lag from input_delay" in body
    assert "step (amplitude 1, time 1), 6 s at 10 Hz, driving f, measuring x, v" in body
    assert re.search(r"output_lag fitted to input_delay\s+38\.25", body)
    assert re.search(r"x\s+0\.005", body)
    assert (tmp_path / "discrimination.png").stat().st_size > 1000

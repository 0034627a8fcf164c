"""The small msd design study shared by the design and API tests."""

import json

from fmuid.design import space_from_json

MSD_SPACE = {
    "input": "f",
    "families": {
        "step": {"amplitude": [0.5, 1.0], "time": [0.5, 2.0]},
        "chirp": {"f0": [0.05, 0.5], "f1": [0.5, 2.0], "amplitude": [0.5, 1.0]},
    },
    "duration": [4.0, 8.0],
    "rates_hz": [5, 10],
    "outputs": {"x": {"sigma": 0.02}, "v": {"sigma": 0.05}},
    "base_outputs": ["x"],
    "max_sensors": 2,
    "longest_test": 8.0,
    "candidates": 4,
    "verify_designs": 1,
    "draws": 2,
    "robust": {"points": 2, "box": {"m": [0.8, 1.4], "k": [3.0, 6.0], "b": [1.0, 2.0]}},
}
MSD_SPEC = {
    "parameters": {
        "m": {"start": 1.1, "lower": 0.1, "upper": 10},
        "k": {"start": 4.4, "lower": 0.1, "upper": 40},
        "b": {"start": 1.6, "lower": 0.1, "upper": 10},
    },
    "inputs": ["f"],
    "outputs": {"x": {"sigma": 0.02}},
}


def space_of(**changes):
    return space_from_json(json.dumps({**MSD_SPACE, **changes}))

"""The small msd design study shared by the design and API tests."""

import json

from fmuid.experiment_design import space_from_json
from fmuid.experiment_design.engine import Screen
from fmuid.experiment_design.verify import DrawTask
from fmuid.progress import Progress

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


SMALL = {"candidates": 2, "draws": 2, "verify_designs": 1, "robust": {"points": 1}}
"""8 trials (2 families x 2 candidates x 2 rates) and 2 verified draws: 10 evaluations."""


def comparable(result_dict):
    """The result JSON without the wall times and provenance, which differ from run to run."""
    out = {**result_dict, "cost": result_dict["cost"]["simulations"]}
    out.pop("provenance", None)
    return out


class Stop(BaseException):
    """Stands for the end of the process (not caught as an error of the job)."""


def counting(monkeypatch):
    """Count the screen and verification evaluations run in this process."""
    calls = {"screen": 0, "verify": 0}
    sens, run = Screen.sensitivities, DrawTask.run

    def sensitivities(self, trial):
        calls["screen"] += 1
        return sens(self, trial)

    def draw(self):
        calls["verify"] += 1
        return run(self)

    monkeypatch.setattr(Screen, "sensitivities", sensitivities)
    monkeypatch.setattr(DrawTask, "run", draw)
    return calls


def stop_after(k):
    """A progress callback that raises :class:`Stop` at its ``k``-th event."""
    seen = []

    def progress(event: Progress):
        seen.append(event)
        if len(seen) == k:
            raise Stop

    return progress

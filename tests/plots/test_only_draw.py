"""Plot functions only draw: no plot module simulates, fits or imports what does."""

import ast
from pathlib import Path

PLOTS = Path(__file__).resolve().parents[2] / "service" / "fmuid" / "plots"
FORBIDDEN_MODULES = ("fmuid.model", "fmuid.stages", "fmuid.estimation.optimize")
FORBIDDEN_NAMES = {
    "Problem",
    "FmuPredictor",
    "make_problem",
    "residual_series",
    "trajectory_band",
    "diagnosis_series",
    "augmented_problem_of",
    "fit_problem",
    "profile_problem",
}
"""What simulates or fits: the engine calls these and hands the plots their results."""
SIMULATING_CALLS = {"predict", "residuals", "chi2", "simulate", "fit", "profile", "diagnose"}


def _offences(path: Path) -> list[str]:
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        where = f"{path.name}:{getattr(node, 'lineno', 0)}"
        if isinstance(node, ast.ImportFrom) and node.module:
            if node.module.startswith(FORBIDDEN_MODULES):
                out.append(f"{where} imports {node.module}")
            out.extend(f"{where} imports {a.name}" for a in node.names if a.name in FORBIDDEN_NAMES)
        elif isinstance(node, ast.Import):
            fmuid = [a.name for a in node.names if a.name.startswith("fmuid")]
            out.extend(f"{where} imports {name}" for name in fmuid)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            if node.func.attr in SIMULATING_CALLS:
                out.append(f"{where} calls .{node.func.attr}()")
    return out


def test_no_plot_module_simulates_or_fits():
    files = sorted(PLOTS.glob("*.py"))
    assert len(files) > 5
    assert [o for path in files for o in _offences(path)] == []

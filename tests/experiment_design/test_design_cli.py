"""``fmuid design`` on the command line: result JSON, report, exit status 2 naming the field."""

import json

from design_cases import MSD_SPACE, MSD_SPEC
from fmuid.cli import main


def test_design_command_writes_result_and_report(tmp_path, capsys):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps(MSD_SPEC))
    space = tmp_path / "E.json"
    space.write_text(json.dumps({**MSD_SPACE, "verify_designs": 0, "candidates": 2}))
    out = tmp_path / "R.json"
    argv = ["design", "--fmu", "msd", "--spec", str(spec), "--space", str(space)]
    assert main([*argv, "--out", str(out), "--report", str(tmp_path / "rep")]) == 0
    result = json.loads(out.read_text())
    first = result["designs"][0]
    assert set(first) >= {"experiment", "predicted", "verified", "score", "cost"}
    assert first["predicted"]["k"]["status"] == "identifiable"
    assert result["not_identifiable_by_any"] == []
    assert any(k.startswith("rate") for k in result["tradeoffs"])
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "Experiment design" in page and "data:image/png;base64," in page  # embedded
    assert (tmp_path / "rep" / "widths.png").is_file()
    assert "recommended:" in capsys.readouterr().out


def test_design_command_bad_space_exits_2_naming_the_field(tmp_path, capsys):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps(MSD_SPEC))
    space = tmp_path / "E.json"
    space.write_text(
        json.dumps({**MSD_SPACE, "outputs": {"z": {"sigma": 1.0}}, "base_outputs": []})
    )
    argv = ["design", "--fmu", "msd", "--spec", str(spec), "--space", str(space)]
    assert main([*argv, "--out", str(tmp_path / "R.json")]) == 2
    assert "outputs: 'z' is not an FMU output" in capsys.readouterr().err


def test_design_command_resumes_from_its_checkpoint(tmp_path):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps(MSD_SPEC))
    space = tmp_path / "E.json"
    space.write_text(json.dumps({**MSD_SPACE, "verify_designs": 0, "candidates": 2}))
    argv = ["design", "--fmu", "msd", "--spec", str(spec), "--space", str(space)]
    keep = tmp_path / "ck"
    assert main([*argv, "--out", str(tmp_path / "a.json"), "--checkpoint", str(keep)]) == 0
    saved = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in keep.rglob("*.npz")}
    assert saved
    assert main([*argv, "--out", str(tmp_path / "b.json"), "--checkpoint", str(keep)]) == 0
    # nothing evaluated again: every saved evaluation is the same file, untouched
    assert {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in keep.rglob("*.npz")} == saved
    a, b = (json.loads((tmp_path / n).read_text()) for n in ("a.json", "b.json"))
    for doc in (a, b):
        doc.pop("cost")
        doc.pop("provenance")
    assert a == b

"""The data folder's layout: the paths an existing data folder holds stay where they are."""

import tempfile
from pathlib import Path

from fmuid.jobs.layout import DataLayout
from fmuid.jobs.records import FINAL_STATUSES, KINDS, STATUSES
from fmuid.jobs.store import JobStore


def test_paths_of_a_data_folder(tmp_path):
    layout = DataLayout(tmp_path)
    assert layout.blob("ab12") == tmp_path / "blobs" / "ab12"
    assert layout.fmu_dir("ab12") == tmp_path / "fmus" / "ab12"
    assert layout.log("j1") == tmp_path / "logs" / "j1.log"
    assert layout.report("j1") == tmp_path / "reports" / "j1"
    assert layout.report_marker("j1") == tmp_path / "reports" / "j1.tmp"
    assert layout.report_error("j1") == tmp_path / "reports" / "j1.error"
    assert layout.checkpoint("j1") == tmp_path / "checkpoints" / "j1"
    assert layout.uploads == tmp_path / "tmp" and layout.reserve == tmp_path / "reserve"


def test_job_temporary_folders_are_short_and_per_data_folder(tmp_path):
    one, other = DataLayout(tmp_path / "a"), DataLayout(tmp_path / "b")
    assert one.job_tmp_root != other.job_tmp_root
    job = "0123abcd-4567-89ef-0123-456789abcdef"
    assert one.job_tmp(job) == one.job_tmp_root / "0123abcd4567"
    assert one.report_work(job) == one.job_tmp_root / "0123abcd4567.r"
    socket = one.report_work(job) / "pymp-xxxxxxxx" / "listener-xxxxxxxx"
    assert len(str(socket).encode()) < 108  # a Unix socket path's limit


def test_a_long_tmpdir_falls_back_to_a_short_one(tmp_path, monkeypatch):
    long = tmp_path / ("t" * 80)
    long.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(long))
    socket = DataLayout(tmp_path).job_tmp("0" * 36) / "pymp-xxxxxxxx" / "listener-xxxxxxxx"
    assert len(str(socket).encode()) < 108 and not socket.is_relative_to(long)


def test_a_job_owns_every_per_job_path_and_no_shared_one(tmp_path):
    layout = DataLayout(tmp_path)
    owned = set(layout.job_files("j1"))
    named = {
        layout.log("j1"),
        layout.report("j1"),
        layout.report_marker("j1"),
        layout.report_error("j1"),
        layout.checkpoint("j1"),
        layout.job_tmp("j1"),
    }
    assert owned == named
    assert not any(p.is_relative_to(layout.blobs) for p in owned)


def test_the_store_keeps_its_files_where_the_layout_says(tmp_path):
    store = JobStore(tmp_path / "jobs.sqlite", tmp_path)
    upload = store.tmp_dir() / "upload"
    upload.write_bytes(b"abc")
    sha = store.add_file(upload)
    assert store.blob_path(sha) == DataLayout(tmp_path).blob(sha)
    assert Path(store.blob_path(sha)).read_bytes() == b"abc"
    assert store.reserve == DataLayout(tmp_path).reserve and store.reserve.is_file()


def test_one_list_of_kinds_and_statuses():
    assert KINDS == ("fit", "profile", "diagnose", "design")
    assert set(FINAL_STATUSES) < set(STATUSES) and "queued" not in FINAL_STATUSES

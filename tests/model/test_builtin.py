import os
import shutil
import time

import pytest

from fmuid.errors import FmuError
from fmuid.model.builtin import builtin_fmu, model_src_dir


def test_builtin_fmus_are_built_when_missing_and_rebuilt_when_stale(tmp_path, monkeypatch):
    src = tmp_path / "src"
    shutil.copytree(model_src_dir(), src)
    monkeypatch.setenv("FMUID_MODEL_SRC", str(src))
    monkeypatch.setenv("FMUID_FMU_DIR", str(tmp_path / "fmus"))
    path = builtin_fmu("msd")
    assert path.is_file()
    first = path.stat().st_mtime_ns
    assert builtin_fmu("msd").stat().st_mtime_ns == first
    later = time.time() + 5
    os.utime(src / "msd" / "model.c", (later, later))
    assert builtin_fmu("msd").stat().st_mtime_ns != first


def test_unknown_builtin_model_is_named():
    with pytest.raises(FmuError, match="tractor_implement"):
        builtin_fmu("tractor")


def test_an_installed_package_builds_into_the_user_cache(tmp_path, monkeypatch):
    from fmuid.model import builtin

    monkeypatch.delenv("FMUID_FMU_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert builtin.fmu_dir() == builtin._repository() / "fmus"  # a source tree: <repo>/fmus
    monkeypatch.setattr(builtin, "_repository", lambda: None)  # as in site-packages
    assert builtin.fmu_dir() == tmp_path / "fmuid" / "fmus" / "0.1.0"
    # the sources ship inside the package
    assert (builtin.model_src_dir() / "msd" / "variables.json").is_file()
    assert builtin.model_src_dir().parent.name == "fmuid"

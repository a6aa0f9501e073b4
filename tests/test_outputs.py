"""Output helpers: a failed write leaves the old file and no temporary file; names stay inside."""

import os

import pytest
import torch

from tsad_drake.errors import UsageError
from tsad_drake.outputs import OutputDir, atomic_write, prepare_out_file
from tsad_drake.runtime import THREAD_ENV_VARS, pin_threads


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "result.json"
    path.write_text("old")

    def half_then_fail(tmp):
        tmp.write_text("half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(path, half_then_fail)
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.json"]


def test_temporary_files_keep_the_suffix_writers_choose_formats_by(tmp_path):
    seen = []
    atomic_write(tmp_path / "depth.npy", lambda tmp: (seen.append(tmp.suffix), tmp.write_bytes(b"")))
    assert seen == [".npy"] and (tmp_path / "depth.npy").exists()


def test_output_dir_refuses_names_that_leave_it(tmp_path):
    folder = OutputDir(tmp_path)
    assert folder.write_text("a.sdf", "x") == tmp_path / "a.sdf"
    for name in ("../a.sdf", "/tmp/a.sdf", "sub/a.sdf", "..", ""):
        with pytest.raises(UsageError):
            folder.write_text(name, "x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.sdf"]


def test_prepare_out_file_replaces_only_what_it_may(tmp_path):
    mine, other = tmp_path / "mine.json", tmp_path / "other.json"
    mine.write_text("mine")
    other.write_text("other")
    assert prepare_out_file(mine, may_replace=lambda p: p.read_text() == "mine") == mine
    with pytest.raises(UsageError, match="exists and is not a bench result"):
        prepare_out_file(other, may_replace=lambda p: p.read_text() == "mine", kind="a bench result")


def test_pin_threads_sets_torch_and_the_environment(monkeypatch):
    for name in THREAD_ENV_VARS:
        monkeypatch.delenv(name, raising=False)
    before = torch.get_num_threads()
    try:
        pin_threads(2)
        assert torch.get_num_threads() == 2
        assert all(os.environ[name] == "2" for name in THREAD_ENV_VARS)
        pin_threads(1)
        assert torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)

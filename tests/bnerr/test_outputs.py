"""Tests of bnerr.outputs: output paths checked before the work, one writer, stale temporaries."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from bnerr.errors import DtypeError
from bnerr.outputs import (
    OutputBusyError,
    OutputPathError,
    check_folder_path,
    check_output,
    clean_stale_temporaries,
    output_lock,
    temporary_name,
    undo_on_failure,
)


def test_a_folder_that_is_an_existing_file_is_refused(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(
        OutputPathError, match=r"--out .*f: expected a folder, got an existing file"
    ):
        check_output(tmp_path / "f", "dir")


def test_a_file_that_is_an_existing_folder_is_refused(tmp_path):
    with pytest.raises(OutputPathError, match="expected a file name, got an existing folder"):
        check_output(tmp_path, "file", name="--out")


def test_a_path_below_a_file_is_refused(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(OutputPathError, match="got .*f, an existing file"):
        check_output(tmp_path / "f" / "sub" / "w.pt", "file")


def test_a_folder_path_is_checked_without_creating_anything(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(OutputPathError, match=r"--cache .*f: expected a folder, got an existing"):
        check_folder_path(tmp_path / "f", "--cache")
    with pytest.raises(OutputPathError, match=r"got .*f, an existing file"):
        check_folder_path(tmp_path / "f" / "sub", "--cache")
    assert check_folder_path(tmp_path / "new" / "sub", "--cache") == tmp_path / "new" / "sub"
    assert not (tmp_path / "new").exists()  # nothing made: the caller creates it when it writes


@pytest.mark.parametrize("path", ["/proc/bnerr-test/out", "/proc/self/bnerr.exr"])
def test_proc_is_not_writable(path):
    kind = "dir" if path.endswith("out") else "file"
    with pytest.raises(OutputPathError, match="expected a (writable folder|folder that can be)"):
        check_output(path, kind)


def test_a_read_only_folder_is_refused(tmp_path, monkeypatch):
    import builtins

    real_open = builtins.open

    def read_only(file, mode="r", *args, **kwargs):
        if "w" in mode:
            raise OSError(30, "Read-only file system")
        return real_open(file, mode, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", read_only)
    with pytest.raises(
        OutputPathError, match="expected a writable folder, got Read-only file system"
    ):
        check_output(tmp_path / "out", "dir")


def test_too_little_free_space_is_refused_and_the_probe_is_gone(tmp_path):
    with pytest.raises(OutputPathError, match="MiB of free disk space for the output, got"):
        check_output(tmp_path / "out", "dir", need_bytes=1e18)
    assert list((tmp_path / "out").iterdir()) == []
    assert (
        check_output(tmp_path / "out" / "a.exr", "file", need_bytes=10)
        == tmp_path / "out" / "a.exr"
    )


def test_bad_arguments_are_typed_errors():
    with pytest.raises(DtypeError):
        check_output(3, "dir")
    with pytest.raises(DtypeError):
        check_output("x", "folder")


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_stale_temporaries_of_dead_writers_are_removed_live_ones_kept(tmp_path):
    dead = tmp_path / f".w.pt.bnerr-tmp-{_dead_pid()}-0123abcd.pt"
    live = temporary_name(tmp_path / "w.pt", ".pt")
    legacy = tmp_path / ".w.pt.ckpt.0123456789ab.tmp.ckpt"
    other_legacy = tmp_path / ".x.pt.0123456789ab.tmp.pt"
    for path in (dead, live, legacy, other_legacy, tmp_path / "w.pt"):
        path.write_bytes(b"x")
    removed = clean_stale_temporaries(tmp_path, names=["w.pt.ckpt"])
    assert removed == sorted([dead, legacy])
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [live.name, other_legacy.name, "w.pt"]
    )


def test_a_named_lock_refuses_a_second_writer_of_that_name_only(tmp_path):
    with output_lock(tmp_path, "bnerr train", lock_name=".a.pt.bnerr.lock"):
        with pytest.raises(OutputBusyError, match="another bnerr train holds its lock"):
            with output_lock(tmp_path, "bnerr train", lock_name=".a.pt.bnerr.lock"):
                pass
        with output_lock(tmp_path, "bnerr train", lock_name=".b.pt.bnerr.lock"):
            pass
    assert os.path.exists(Path(tmp_path) / ".a.pt.bnerr.lock")


def test_undo_on_failure_removes_what_the_block_created_and_keeps_the_rest(tmp_path):
    """Issue 54: a command that fails after it began writing leaves nothing half-written: new
    files, new folders, the lock file and the output folder itself (when it was new) go; what
    was there before stays; a busy folder (another process writing) is not touched."""
    out = tmp_path / "out"
    with pytest.raises(RuntimeError), undo_on_failure(out, "test"):
        (out / "crops").mkdir()
        (out / "crops" / "a.npz").write_bytes(b"x")
        (out / "cells.jsonl").write_text("{}\n")
        raise RuntimeError("late")
    assert not out.exists()
    out.mkdir()
    (out / "mine.txt").write_text("kept")
    with pytest.raises(KeyboardInterrupt), undo_on_failure(out, "test"):
        (out / "cells.jsonl").write_text("{}\n")
        raise KeyboardInterrupt
    assert sorted(p.name for p in out.iterdir()) == ["mine.txt"]
    with undo_on_failure(out, "test"):  # success: everything stays
        (out / "cells.jsonl").write_text("{}\n")
    assert (out / "cells.jsonl").is_file() and (out / ".bnerr.lock").is_file()
    with output_lock(out, "another"):  # busy: refused, and the other writer's files kept
        (out / "theirs.npz").write_bytes(b"y")
        with pytest.raises(OutputBusyError), undo_on_failure(out, "test"):
            pass
        assert (out / "theirs.npz").is_file() and (out / ".bnerr.lock").is_file()

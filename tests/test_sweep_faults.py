"""Faults during a sweep (benchmarks.sweep.runner, records, references, tuning): the driver killed
mid-sweep and mid-append, a full disk during a results append and during a reference write, a
read-only reference cache, a corrupted ``tuned_params.json``.

In each: a clear message (an error naming the file and what to do, or a warning where the sweep
can go on), nothing half-written (whole lines in ``cells.jsonl``, no partial file in the cache),
and ``--resume`` gives the records of an uninterrupted run (everything but the timings).

The full disk and the read-only folder are real where the tests run as root (a small tmpfs:
tests/_disks.py); elsewhere those cases skip and their ``injected`` twin raises the kernel's
``OSError(ENOSPC)`` at the write call instead. The kills are real ``SIGKILL``s of a child process
running the serial runner (between two runs, with a rename pending, and in the middle of an
append; about 3-10 s each, most of it the child's imports). The Ray worker's kill is in
tests/test_ray_runner.py. Everything renders with the real tracer at 16x12 (a sweep takes under a
second).
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import signal
import subprocess
import sys
from contextlib import nullcontext
from pathlib import Path

import pytest

from benchmarks.sweep import records as records_module
from benchmarks.sweep import references as references_module
from benchmarks.sweep.parts import real_parts
from benchmarks.sweep.records import RESULTS_FILE, load_records
from benchmarks.sweep.runner import TUNED_PARAMS_FILE, run_suite
from bnerr.outputs import OutputPathError
from tests._disks import fill, no_space, read_only, small_disk
from tests._suites import tiny_suite

pytestmark = pytest.mark.usefixtures("one_thread")

ROOT = Path(__file__).resolve().parents[1]
#: Renders of the white run with its references cached (2 tuning frames, 2 x 2 measured): the
#: next render is the temporal run's first.
WHITE_RENDERS = 6


def _measured(records):
    """Everything of the records but their timings, in file order."""
    out = []
    for record in records:
        data = record.to_json()
        del data["timings"]
        out.append(data)
    return out


class _OnRender:
    """The renderer, calling ``hook`` once before render number ``at`` (counted from 0)."""

    def __init__(self, at, hook):
        self.render, self.at, self.hook, self.calls = real_parts().render, at, hook, 0

    def __call__(self, *args, **kwargs):
        if self.calls == self.at:
            self.hook()
        self.calls += 1
        return self.render(*args, **kwargs)


def _parts(render=None):
    parts = real_parts()
    return parts if render is None else dataclasses.replace(parts, render=render)


def _resume(out, cache, **kwargs):
    return run_suite(tiny_suite(), out, cache_dir=cache, resume=True, progress=False, **kwargs)


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """The uninterrupted sweep: (output dir, cache dir, records)."""
    out, cache = tmp_path_factory.mktemp("whole"), tmp_path_factory.mktemp("cache")
    return out, cache, run_suite(tiny_suite(), out, cache_dir=cache, progress=False)


def _check_resumes(whole, out, cache, first=None):
    """Resume ``out`` and check the records and files are the uninterrupted run's."""
    _, _, records = whole
    done = _resume(out, cache)
    assert _measured(done) == _measured(records)
    assert _measured(load_records(out)) == _measured(records)  # whole lines, each cell once
    stored = json.loads((out / TUNED_PARAMS_FILE).read_text())
    assert stored == json.loads((whole[0] / TUNED_PARAMS_FILE).read_text())
    for rec in done:  # the cells written before the fault were kept, not measured again
        if first is not None and rec.key in first:
            assert rec == first[rec.key]
    assert not [p.name for p in out.iterdir() if ".bnerr-tmp-" in p.name]


# -- the driver killed --------------------------------------------------------------------------

_KILLED = """
import dataclasses, os, signal, sys
import torch
sys.path.insert(0, {tests!r})
torch.set_num_threads(1)
from tests._suites import tiny_suite
from test_sweep_faults import _parts, _Os
from benchmarks.sweep import records
from benchmarks.sweep.runner import run_suite

def die():
    os.kill(os.getpid(), signal.SIGKILL)

if {where!r} == "rename":  # between two runs, tuned_params.json written to its temporary only
    import bnerr.io
    render, replace, seen = None, os.replace, []
    def dying_replace(src, dst):
        seen.append(str(dst))
        if seen.count(str(dst)) == 2 and str(dst).endswith("tuned_params.json"):
            die()  # the temporal run's save
        return replace(src, dst)
    bnerr.io.os = _Os(replace=dying_replace)
else:  # in the middle of the temporal run's append: half its bytes written
    render = None
    write = os.write
    def torn(fd, data):
        if os.readlink(f"/proc/self/fd/{{fd}}").endswith("cells.jsonl"):
            write(fd, bytes(data[: len(data) // 2]))
            die()
        return write(fd, data)
    records.os = _Os(write=torn)
run_suite(tiny_suite(), {out!r}, parts=_parts(render), cache_dir={cache!r}, progress=False)
"""


@pytest.mark.parametrize("where", ["rename", "append"])
def test_a_driver_killed_mid_sweep_resumes_to_the_same_records(whole, tmp_path, where):
    _, cache, records = whole
    out = tmp_path / "out"
    script = _KILLED.format(tests=str(ROOT / "tests"), where=where, out=str(out), cache=str(cache))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "tests")])}
    done = subprocess.run([sys.executable, "-c", script], env=env, cwd=ROOT, timeout=120)
    assert done.returncode == -signal.SIGKILL
    left = [p.name for p in out.iterdir() if ".bnerr-tmp-" in p.name]
    assert len(left) == (where == "rename")  # the killed rename's temporary, removed on resume
    data = (out / RESULTS_FILE).read_bytes()
    assert data.endswith(b"\n") == (where != "append")  # the append's half line: a torn tail
    with pytest.warns(UserWarning, match="cut short") if where == "append" else nullcontext():
        first = {r.key: r for r in load_records(out, torn_tail=True)}
    assert {r.cell.strategy for r in first.values()} == {"white"}
    _check_resumes(whole, out, cache, first)


def test_a_reference_write_cut_by_a_kill_leaves_a_temporary_the_next_sweep_removes(whole, tmp_path):
    _, _, records = whole
    dead = subprocess.Popen(["true"])
    dead.wait()  # a writer process that no longer runs
    stale = tmp_path / "cache" / "direct" / f".ref.exr.bnerr-tmp-{dead.pid}-0123abcd.exr"
    stale.parent.mkdir(parents=True)
    stale.write_bytes(b"half an EXR")
    done = run_suite(tiny_suite(), tmp_path / "out", cache_dir=tmp_path / "cache", progress=False)
    assert _measured(done) == _measured(records)
    assert not stale.exists() and list(stale.parent.glob("*.exr"))


# -- a full disk ---------------------------------------------------------------------------------


def _fill_at_append(monkeypatch, out, mode):
    """Make the temporal run's append meet a full disk: fill the tmpfs when its first frame
    renders, or inject ENOSPC after half the bytes at the append's ``write``."""
    if mode == "tmpfs":
        return _OnRender(WHITE_RENDERS, lambda: fill(out))
    write = os.write

    def half_then_full(fd, data):
        if not os.readlink(f"/proc/self/fd/{fd}").endswith(RESULTS_FILE):
            return write(fd, data)
        if len(data) > 1:
            return write(fd, bytes(data[: len(data) // 2]))
        raise no_space()

    monkeypatch.setattr(records_module, "os", _Os(write=half_then_full))
    return None


class _Os:
    """The ``os`` module with some functions replaced (for one module's view of it)."""

    def __init__(self, **replaced):
        self.replaced = replaced

    def __getattr__(self, name):
        return self.replaced.get(name) or getattr(os, name)


@pytest.mark.parametrize("mode", ["tmpfs", "injected"])
def test_a_full_disk_during_an_append_keeps_whole_lines_and_resumes(
    whole, tmp_path, monkeypatch, mode
):
    _, cache, _ = whole
    out = tmp_path / "out"
    with small_disk(out) if mode == "tmpfs" else nullcontext():
        render = _fill_at_append(monkeypatch, out, mode)
        with pytest.raises(OutputPathError) as err:
            run_suite(tiny_suite(), out, parts=_parts(render), cache_dir=cache, progress=False)
        message = str(err.value)
        assert "No space left on device" in message and "--resume" in message
        assert RESULTS_FILE in message and "\n" not in message
        first = {r.key: r for r in load_records(out)}  # no torn tail: the append was undone
        assert {r.cell.strategy for r in first.values()} == {"white"}
        monkeypatch.undo()
        (out / "filler").unlink(missing_ok=True)
        _check_resumes(whole, out, cache, first)


def test_a_full_disk_during_a_reference_write_warns_and_leaves_no_partial_file(whole, tmp_path):
    _, _, records = whole
    cache = tmp_path / "cache"
    with small_disk(cache):
        (cache / "direct").mkdir()
        fill(cache, leave=0)
        with pytest.warns(UserWarning, match="No space left on device") as said:
            done = run_suite(tiny_suite(), tmp_path / "out", cache_dir=cache, progress=False)
        assert len([w for w in said if "writable reference cache" in str(w.message)]) == 1
        assert _measured(done) == _measured(records)
        assert list((cache / "direct").iterdir()) == []  # nothing half-written, no temporaries


def test_an_injected_full_disk_at_the_reference_write_warns_once_and_goes_on(
    whole, tmp_path, monkeypatch
):
    _, _, records = whole
    tries = []

    def refuse(path, frame):
        tries.append(path)
        message = f"{path}: expected a writable file, got No space left on device"
        raise OutputPathError(message) from no_space(path)  # as atomic_write raises it

    monkeypatch.setattr(references_module, "write_frame", refuse)
    cache = tmp_path / "cache"
    with pytest.warns(UserWarning, match="No space left on device"):
        done = run_suite(tiny_suite(), tmp_path / "out", cache_dir=cache, progress=False)
    assert _measured(done) == _measured(records)
    assert len(tries) == 1  # said once, not tried for every reference


# -- a read-only cache ----------------------------------------------------------------------------


def test_a_cache_that_is_a_file_is_an_error_not_a_warning(tmp_path):
    (tmp_path / "cache").write_text("not a folder")
    with pytest.raises(OSError, match="cache"):
        run_suite(tiny_suite(), tmp_path / "out", cache_dir=tmp_path / "cache", progress=False)


def test_a_read_only_empty_cache_warns_and_measures_the_same_cells(whole, tmp_path):
    _, _, records = whole
    with read_only(tmp_path / "cache") as cache:
        with pytest.warns(UserWarning, match="expected a writable reference cache"):
            done = run_suite(tiny_suite(), tmp_path / "out", cache_dir=cache, progress=False)
        assert _measured(done) == _measured(records)
        assert list(cache.iterdir()) == []


def test_a_read_only_cache_with_the_references_is_read_without_a_word(whole, tmp_path, recwarn):
    _, full_cache, records = whole
    shutil.copytree(full_cache, tmp_path / "cache")
    with read_only(tmp_path / "cache") as cache:
        counting = _OnRender(-1, lambda: None)
        done = run_suite(
            tiny_suite(), tmp_path / "out", parts=_parts(counting), cache_dir=cache, progress=False
        )
    assert _measured(done) == _measured(records)
    assert (
        counting.calls == WHITE_RENDERS + 2 * 3
    )  # temporal: warmup 1 + 2 frames  # no reference rendered: all were read
    assert not [w for w in recwarn if "cache" in str(w.message)]


# -- a corrupted tuned_params.json ----------------------------------------------------------------


@pytest.mark.parametrize(
    "garbage",
    [b"", b'{"format": "bnerr-tuned-params/1", "entr', b"\xff\xfe\x00", b'{"format": "other"}'],
    ids=["empty", "torn", "binary", "other-format"],
)
def test_a_corrupted_tuned_params_file_is_tuned_again_on_resume(whole, tmp_path, garbage):
    out, cache, records = whole
    lines = (out / RESULTS_FILE).read_bytes().splitlines(keepends=True)
    (tmp_path / RESULTS_FILE).write_bytes(b"".join(lines[:2]))  # the white run's cells
    (tmp_path / TUNED_PARAMS_FILE).write_bytes(garbage)
    with pytest.warns(UserWarning, match=f"{TUNED_PARAMS_FILE}.*tuned again"):
        _check_resumes(whole, tmp_path, cache, {r.key: r for r in load_records(tmp_path)})

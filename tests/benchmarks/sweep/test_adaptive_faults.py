"""Faults during an adaptive run (``bnerr bench --until-resolved``, benchmarks.sweep.adaptive),
as tests/benchmarks/sweep/test_runner_faults.py does for a plain sweep: the driver stopped
between two batches, a full disk during a batch's append, a plug-in changed between batches.

In each, ``--resume`` continues to the records (everything but the timings) and so the verdicts
of an uninterrupted run, or, for a changed plug-in, refuses in one line naming it. The stop is
an exception from a patched hook between the rounds (a real SIGKILL of the serial runner is
test_runner_faults.py's); the full disk an injected ``OSError(ENOSPC)`` at the append's write.
Everything renders with the real tracer at 16x12: white and temporal at 1 spp, one denoiser,
2 seed sets first, then batches of 2 up to a cap of 6.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from benchmarks.reports.decision import cell_verdicts
from benchmarks.reports.table import summarize
from benchmarks.sweep import adaptive
from benchmarks.sweep import records as records_module
from benchmarks.sweep.records import RESULTS_FILE, final_records, load_records
from bnerr.outputs import OutputPathError
from tests._disks import no_space
from tests._probes import refused_on_the_command_line
from tests._suites import tiny_suite

pytestmark = pytest.mark.usefixtures("one_thread")

CAP, BATCH = 6, 2


def _suite():
    return tiny_suite(denoisers=("gaussian",), seed_sets=2)


def _run(out: Path, cache: Path, **kwargs):
    return adaptive.run_until_resolved(
        _suite(), out, cap=CAP, batch=BATCH, cache_dir=cache, progress=False, **kwargs
    )


def _measured(records):
    """Everything of the records but their timings, in file order."""
    out = []
    for record in records:
        data = record.to_json()
        del data["timings"]
        out.append(data)
    return out


def _verdicts(records):
    return cell_verdicts(summarize(final_records(records)))


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """The uninterrupted adaptive run: (cache dir, records); it adds at least one batch."""
    out, cache = tmp_path_factory.mktemp("whole"), tmp_path_factory.mktemp("cache")
    records = _run(out, cache)
    assert len({r.cell.seed_sets for r in records}) > 1, "expected a run that adds a batch"
    return cache, records


def _check_resumes(whole, out: Path, kept: list) -> None:
    """Resume ``out``: the uninterrupted run's records and verdicts, ``kept`` not measured
    again, no temporary left."""
    cache, records = whole
    done = _run(out, cache, resume=True)
    assert _measured(load_records(out)) == _measured(records)
    assert _verdicts(done) == _verdicts(records)
    by_key = {r.key: r for r in done}
    assert all(by_key[r.key] == r for r in kept)  # the records before the fault: kept as written
    assert not [p.name for p in out.iterdir() if ".bnerr-tmp-" in p.name]


class _Stop(BaseException):
    """What a kill between two batches leaves: the process ends, nothing else runs."""


def test_a_run_stopped_between_batches_resumes_to_the_same_verdicts(whole, tmp_path, monkeypatch):
    grow, rounds = adaptive.grow, []

    def stop_after_first(runs, records, *scope):
        rounds.append(len(records))
        if len(rounds) == 1:
            raise _Stop
        return grow(runs, records, *scope)

    monkeypatch.setattr(adaptive, "grow", stop_after_first)
    out = tmp_path / "out"
    with pytest.raises(_Stop):
        _run(out, whole[0])
    monkeypatch.undo()
    kept = load_records(out)
    assert kept and {r.cell.seed_sets for r in kept} == {2}  # the first batch, whole
    _check_resumes(whole, out, kept)


def test_a_full_disk_during_a_batch_keeps_whole_lines_and_resumes(whole, tmp_path, monkeypatch):
    out, write, grow, rounds = tmp_path / "out", os.write, adaptive.grow, []

    class _Os:
        def __getattr__(self, name):
            return full_on_second_batch if name == "write" else getattr(os, name)

    def full_on_second_batch(fd, data):
        if not rounds or not os.readlink(f"/proc/self/fd/{fd}").endswith(RESULTS_FILE):
            return write(fd, data)  # the first batch's records go in whole
        if len(data) > 1:
            return write(fd, bytes(data[: len(data) // 2]))  # half of it, then the disk is full
        raise no_space()

    monkeypatch.setattr(records_module, "os", _Os())
    monkeypatch.setattr(adaptive, "grow", lambda *a: rounds.append(1) or grow(*a))
    with pytest.raises(OutputPathError) as err:
        _run(out, whole[0])
    message = str(err.value)
    assert "No space left on device" in message and "--resume" in message and "\n" not in message
    monkeypatch.undo()
    kept = load_records(out)  # no torn tail: the append was undone
    assert 2 in {r.cell.seed_sets for r in kept} and len(kept) < len(whole[1])
    assert (out / RESULTS_FILE).read_bytes().endswith(b"\n")
    _check_resumes(whole, out, kept)


DENOISER = '''
import torch.nn.functional as F


def box(frame):
    """A 3x3 box filter."""
    return F.avg_pool2d(frame.color[None], 3, 1, 1, count_include_pad=False)[0]


box.name = "probe_box"
box.kind = "filter"
'''


def _bench(tmp_path: Path, *extra: str) -> list[str]:
    return [
        "bench", "--suite", "quick", "--scenes", "direct", "--strategies", "white", "temporal",
        "--denoisers", f"{tmp_path / 'box.py'}:box", "--metrics", "mse", "--spp", "1",
        "--frames", "2", "--warmup", "1", "--res", "16x12", "--reference-spp", "16",
        "--seed-sets", "2", "--until-resolved", "--seed-set-cap", str(CAP), "--batch",
        str(BATCH), "--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache"),
        "--quiet", "--no-charts", *extra,
    ]  # fmt: skip


def test_a_plugin_changed_between_batches_is_refused_in_one_line_naming_it(
    tmp_path, monkeypatch, capsys, forget
):
    """The plug-in's file changes after the first batch: the run refuses to mix its records
    with the changed one's, in one line naming it; ``--resume`` refuses the same way while the
    file differs, and completes once it is restored."""
    forget.append(("bnerr.denoisers", "probe_box"))
    plugin = tmp_path / "box.py"
    plugin.write_text(DENOISER)
    grow, rounds = adaptive.grow, []

    def change_after_first(runs, records, *scope):
        rounds.append(1)
        if len(rounds) == 1:
            plugin.write_text(DENOISER + "# changed\n")
        return grow(runs, records, *scope)

    monkeypatch.setattr(adaptive, "grow", change_after_first)
    refused_on_the_command_line(_bench(tmp_path), capsys, r"plug-in 'probe_box'.*box\.py:box")
    monkeypatch.undo()
    kept = (tmp_path / "out" / RESULTS_FILE).read_text().splitlines()
    assert kept and {json.loads(line)["cell"]["seed_sets"] for line in kept} == {2}
    changed = r"--resume: expected plug-in 'probe_box' \(.*box\.py:box\) unchanged"
    refused_on_the_command_line(_bench(tmp_path, "--resume"), capsys, changed)
    plugin.write_text(DENOISER)
    from benchmarks.cli import main

    assert main(_bench(tmp_path, "--resume")) == 0, capsys.readouterr().err
    lines = (tmp_path / "out" / RESULTS_FILE).read_text().splitlines()
    assert lines[: len(kept)] == kept and len(lines) > len(kept)

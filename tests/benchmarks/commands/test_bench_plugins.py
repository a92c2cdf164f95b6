"""Plug-ins on the command line, each in a subprocess: an installed denoiser package (a
``*.dist-info`` with ``entry_points.txt`` on PYTHONPATH), a strategy with a new family from
``file.py:Name``, a sampler from ``file.py:Name``, a metric and a scene from ``module:attr``, run
by ``bnerr bench`` beside white and a shipped denoiser; then ``--resume`` after the strategy's
file changed refuses with one line naming it."""

import csv
import dataclasses
import subprocess
import textwrap
from pathlib import Path

import pytest

from benchmarks.sweep.plugins import load_recorded
from tests._paths import bnerr_cli
from tests._plugin_sources import SAMPLER, STRATEGY
from tests._records import small_record

PACKAGE = '''
import torch.nn.functional as F


def box(frame):
    """A 3x3 box filter."""
    return F.avg_pool2d(frame.color[None], 3, 1, 1, count_include_pad=False)[0]


box.name = "box3"
box.kind = "filter"
'''

MODULE = '''
import dataclasses

from renderers.catalog import direct


def tiny():
    return dataclasses.replace(direct(), name="tiny")


def maxerr(pred, ref):
    """the largest absolute error"""
    return float((pred - ref).abs().max())
'''


def _install(site: Path) -> None:
    (site / "boxden").mkdir(parents=True)
    (site / "boxden" / "__init__.py").write_text(PACKAGE)
    info = site / "boxden-1.2.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: boxden\nVersion: 1.2\n")
    (info / "entry_points.txt").write_text("[bnerr.denoisers]\nbox3 = boxden:box\n")
    (info / "RECORD").write_text("")
    scenes = site / "tinyscene-0.1.dist-info"
    scenes.mkdir()
    (scenes / "METADATA").write_text("Metadata-Version: 2.1\nName: tinyscene\nVersion: 0.1\n")
    (scenes / "entry_points.txt").write_text("[bnerr.scenes]\ntiny_installed = plugmod:tiny\n")
    (site / "plugmod.py").write_text(MODULE)


def _bnerr(site: Path, *args: str) -> subprocess.CompletedProcess:
    return bnerr_cli(*args, path=[site])


@pytest.fixture
def site(tmp_path):
    _install(tmp_path / "site")
    (tmp_path / "strat.py").write_text(textwrap.dedent(STRATEGY))
    (tmp_path / "samp.py").write_text(textwrap.dedent(SAMPLER))
    return tmp_path


def _bench(tmp_path: Path, *extra: str) -> list[str]:
    return [
        "bench", "--suite", "quick", "--scenes", "plugmod:tiny",
        "--strategies", f"{tmp_path / 'strat.py'}:Mine", "--denoisers", "gaussian", "box3",
        "--samplers", f"{tmp_path / 'samp.py'}:Hashy", "--metrics", "mse", "plugmod:maxerr",
        "--spp", "1", "--frames", "1", "--warmup", "0", "--res", "8x8",
        "--reference-spp", "4", "--seed-sets", "1", "--out", str(tmp_path / "out"),
        "--cache", str(tmp_path / "cache"), "--quiet", "--no-charts", *extra,
    ]  # fmt: skip


def test_bench_measures_every_kind_of_plugin_and_resume_refuses_a_changed_one(site):
    done = _bnerr(site / "site", *_bench(site))
    assert done.returncode == 0, done.stderr
    assert "added the white baseline" in done.stderr
    rows = list(csv.DictReader((site / "out" / "table.csv").open()))
    cells = {(r["scene"], r["strategy"], r["denoiser"]) for r in rows}
    assert {("tiny", s, d) for s in ("white", "mine") for d in ("gaussian", "box3")} <= cells
    assert any("maxerr" in column for column in rows[0])
    page = (site / "out" / "index.html").read_text()
    assert all(word in page for word in ("mine", "box3", "tiny"))
    records = (site / "out" / "cells.jsonl").read_text()
    # the version and the module's source (issue 54: an edit without a version bump is seen)
    assert '"bnerr.denoisers:box3": {"fingerprint": "boxden==1.2+sha256:' in records
    assert '"bnerr.samplers:hashy"' in records and "strat.py:Mine" in records

    (site / "strat.py").write_text(textwrap.dedent(STRATEGY) + "# changed\n")
    refused = _bnerr(site / "site", *_bench(site, "--resume"))
    assert refused.returncode == 2
    last = refused.stderr.strip().splitlines()[-1]
    assert "plug-in 'mine'" in last and "strat.py:Mine" in last and "--resume" in last


def test_installed_plugins_are_listed_like_shipped_ones(site):
    listed = _bnerr(site / "site", "scenes")
    assert listed.returncode == 0, listed.stderr
    assert "tiny_installed" in listed.stdout and "cornell" in listed.stdout


def test_a_recorded_plugin_that_cannot_be_loaded_any_more_is_named_not_fatal(tmp_path):
    gone = {"spec": str(tmp_path / "gone.py") + ":maxerr", "fingerprint": "sha256:0"}
    installed = {"spec": "entry point box3", "fingerprint": "boxden==1.2"}
    pairs = [[[1.0, 1.0]]]
    record = small_record("white", "gaussian", raw={"mse": pairs}, den={"mse": pairs}, frames=1,
                          seed_sets=1)  # fmt: skip
    record = dataclasses.replace(
        record, plugins={"bnerr.metrics:maxerr": gone, "bnerr.denoisers:box3": installed}
    )
    notes = load_recorded([record, record])  # each spec once
    assert len(notes) == 2  # issue 54: an entry point not installed here is named too
    assert notes[0].startswith(f"plug-in 'maxerr' ({gone['spec']}) not loaded, reported from")
    assert notes[1].startswith("plug-in 'box3' (entry point box3 of group bnerr.denoisers, ")


#: A strategy and a sampler whose renders only they could give: every pixel of every frame and
#: seed set the same seed (CONSTANT), and every sample 0.5 (HALF). A silent fall back to white or
#: to the per-pixel sampler gives each seed set other frames.
USED = """
import torch

from bnerr.sequences import WhiteSampler
from bnerr.strategies import WhiteStrategy


class Constant(WhiteStrategy):
    name = "used_constant"
    family = "experimental"
    stream = 0x51A7E154

    def _frame(self, t, render):
        seeds = torch.full((self.height, self.width), 7, dtype=torch.int64, device=self.device)
        return render(seeds, self.sampler)


class Half(WhiteSampler):
    name = "used_half"

    def _sample(self, seed, index, dim, count, pixel):
        return torch.full((seed.numel(), count), 0.5, dtype=torch.float32, device=seed.device)
"""


def test_a_plug_in_strategy_and_sampler_are_the_ones_that_render(tmp_path, forget):
    """Issue 54: the tests' plug-ins subclass white, so a silent fall back to white would pass.
    These render what only they can: the constant strategy gives every seed set the same frames
    (white's differ), the half sampler a noise-free frame (every seed set the same too)."""
    from benchmarks.cli import main
    from benchmarks.sweep.records import load_records

    (tmp_path / "used.py").write_text(USED)
    forget += [("bnerr.strategies", "used_constant"), ("bnerr.samplers", "used_half")]
    args = [
        "bench", "--suite", "quick", "--scenes", "direct",
        "--strategies", "white", f"{tmp_path / 'used.py'}:Constant",
        "--samplers", "owen_sobol", f"{tmp_path / 'used.py'}:Half",
        "--denoisers", "gaussian", "--metrics", "mse", "--spp", "1", "--frames", "1",
        "--warmup", "0", "--res", "8x8", "--reference-spp", "2", "--seed-sets", "3",
        "--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache"), "--quiet",
        "--no-charts",
    ]  # fmt: skip
    assert main(args) == 0
    raw = {
        (r.cell.strategy, r.cell.sampler): [s[0][0] for s in r.raw["mse"]]
        for r in load_records(tmp_path / "out")
        if r.cell.region == "all" and r.cell.denoiser == "gaussian"
    }
    assert set(raw) == {(s, p) for s in ("white", "used_constant")
                        for p in ("owen_sobol", "used_half")}  # fmt: skip
    spread = {key: len(set(values)) for key, values in raw.items()}
    assert spread[("white", "owen_sobol")] == 3  # white: fresh seeds per seed set
    assert spread[("used_constant", "owen_sobol")] == 1  # the same seeds in every seed set
    assert spread[("white", "used_half")] == spread[("used_constant", "used_half")] == 1
    assert raw[("white", "used_half")] == raw[("used_constant", "used_half")]  # no noise at all

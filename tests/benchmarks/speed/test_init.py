"""Tests of benchmarks.speed: every script's figures land in speed.json, and speed.md shows one
table per part with units and the ratio to its anchor."""

import json

import pytest
import torch

from benchmarks.speed import run_speed, speed_markdown
from benchmarks.speed.copy import JOB_BYTES, PASS_JOBS
from benchmarks.speed.copy import measure as measure_copy
from benchmarks.speed.denoise import goal_met
from benchmarks.speed.denoise import table as denoise_table
from benchmarks.speed.formatting import fmt, ratio
from benchmarks.speed.masks import WHITE_LOW_FREQUENCY
from benchmarks.suites import Suite, get_suite
from bnerr.errors import UnknownNameError
from tests._paths import RESULTS

SHIPPED = RESULTS / "speed" / "speed.json"


def test_speed_suite_stores_each_scripts_figures(tmp_path, monkeypatch):
    # The speed scripts time 1080p work for minutes; their own tests cover them. Here only the
    # plumbing: every script's measure() is called and its figures land in JSON and Markdown.
    import benchmarks.speed.masks as speed_masks

    def measure():
        """Seconds per mask."""
        return {"scalar_64": {"seconds": 0.5, "low_frequency_fraction": torch.tensor(0.01)}}

    monkeypatch.setattr(speed_masks, "measure", measure)
    suite = Suite("speed", "timings", scripts=("speed.masks",))
    text = run_speed(suite, tmp_path, progress=False)
    stored = json.loads((tmp_path / "speed.json").read_text())
    assert stored == {
        "speed.masks": {
            "scalar_64": {"seconds": 0.5, "low_frequency_fraction": pytest.approx(0.01)}
        }
    }
    assert "| scalar, 64 x 64 | 0.500 | 0.0100 | 0.204x |" in text
    assert (tmp_path / "speed.md").read_text() == text


def test_the_permutation_anchor_is_measured_right_after_it(tmp_path, monkeypatch):
    import benchmarks.speed.copy as speed_copy
    import benchmarks.speed.permute as speed_permute

    calls = []

    def permute():
        calls.append("permute")
        return {"sort_pass_lum_ms": 4.0, "retarget_ms": 3.0, "size": "40x10, block 4"}

    def copy():
        calls.append("copy")
        return {"sort_lum": {"bytes": 8400, "copy_ms": 2.0}, "retarget": {"bytes": 6400}}

    monkeypatch.setattr(speed_permute, "measure", permute)
    monkeypatch.setattr(speed_copy, "measure", copy)
    text = run_speed(Suite("speed", "t", scripts=("speed.permute",)), tmp_path, progress=False)
    assert calls == ["permute", "copy"]
    assert set(json.loads((tmp_path / "speed.json").read_text())) == {"speed.permute", "speed.copy"}
    # 8400 bytes in 4 ms: 0.0021 GB/s; twice the copy's 2 ms.
    assert "| sort pass, luminance key | 4.00 | 0.00840 | 0.00210 | 2.00 | 2.00x |" in text
    assert "| retargeting pass | 3.00 | 0.00640 | 0.00213 | - | - |" in text
    assert "## speed.copy" not in text and "No memory-copy anchor" not in text


def test_only_the_named_scripts_are_measured_again(tmp_path, monkeypatch):
    # After a change to one kernel, --scripts re-measures its script (with its anchor, side by
    # side) and keeps the other scripts' figures from the speed.json already there.
    import benchmarks.speed.copy as speed_copy
    import benchmarks.speed.masks as speed_masks
    import benchmarks.speed.permute as speed_permute

    calls = []
    monkeypatch.setattr(speed_masks, "measure", lambda: calls.append("masks") or {"m": 1.0})
    monkeypatch.setattr(speed_permute, "measure", lambda: calls.append("permute") or {"p": 2.0})
    monkeypatch.setattr(speed_copy, "measure", lambda: calls.append("copy") or {"c": 3.0})
    suite = Suite("speed", "t", scripts=("speed.masks", "speed.permute"))
    run_speed(suite, tmp_path, progress=False)
    monkeypatch.setattr(speed_permute, "measure", lambda: calls.append("permute") or {"p": 5.0})
    run_speed(suite, tmp_path, progress=False, only=["speed.permute"])
    assert calls == ["masks", "permute", "copy", "permute", "copy"]
    stored = json.loads((tmp_path / "speed.json").read_text())
    want = {"speed.masks": {"m": 1.0}, "speed.permute": {"p": 5.0}, "speed.copy": {"c": 3.0}}
    assert stored == want
    with pytest.raises(UnknownNameError, match="speed.tracer"):
        run_speed(suite, tmp_path, progress=False, only=["speed.tracer"])


def test_the_shipped_figures_give_one_table_per_part():
    figures = json.loads(SHIPPED.read_text())
    text = speed_markdown(get_suite("speed"), figures, {})
    assert "| figure | value |" not in text
    headings = [line for line in text.splitlines() if line.startswith("## ")]
    assert [h.split(" (")[0] for h in headings] == [
        "## Tracer against Mitsuba 3",
        "## `bnerr render` as a new process",
        "## Permutation passes against a memory copy",
        "## Closing-the-gap options against the sort pass",
        "## Samplers against independent values",
        "## Samplers in a render",
        "## Masks",
        "## Denoisers against OIDN",
    ]
    # every figure of the shipped file lands in its table, formatted, with its ratio to its anchor
    oidn = figures["speed.denoise"]["oidn"]
    assert f"| oidn | {fmt(oidn)} | {fmt(1 / oidn)} | 1 (anchor) |" in text
    for name, seconds in figures["speed.denoise"].items():
        if name != "oidn":
            row = f"| {name} | {fmt(seconds)} | {fmt(1 / seconds)} | {ratio(seconds, oidn)} |"
            assert row in text
    llvm = figures["speed.tracer"]["direct"]["ratio_llvm_ad_rgb"]
    assert "| direct | Mitsuba llvm_ad_rgb |" in text and f"| {fmt(1 / llvm)}x |" in text
    assert "No memory-copy anchor in these figures" not in text  # this run measured the copy


def test_failures_gaps_and_unknown_scripts():
    figures = {
        "speed.tracer": {
            "settings": {"width": 8},
            "direct": {
                "bnerr": {"best_s": 1.0, "median_s": 1.0, "warmup_s": 2.0, "samples_per_s": 5e6},
                "mitsuba_scalar_rgb": "no module named mitsuba",
                "mitsuba_llvm_ad_rgb": None,
                "ratio_scalar_rgb": None,
            },
        },
        "speed.permute": {"sort_pass_lum_ms": 2.0, "gap": {"groups_ms": 3.0}, "size": "?"},
        "speed.denoise": {"oidn": None, "gaussian": 0.5},
        "other": {"x": {"y": 1.23456789}},
    }
    text = speed_markdown(Suite("speed", "d", scripts=()), figures, {"other": "What x is."})
    assert "| direct | Mitsuba scalar_rgb | failed: no module named mitsuba | - |" in text
    assert "| direct | Mitsuba llvm_ad_rgb | - | - |" in text
    assert "| groups | 3.00 | 1.50x |" in text
    assert "| gaussian | 0.500 | 2.00 | - |" in text and "| oidn | - | - | 1 (anchor) |" in text
    assert text.endswith(
        "## other\n\nWhat x is.\n\n| figure | value |\n|---|---|\n| x/y | 1.23457 |\n"
    )


@pytest.mark.parametrize(
    ("value", "shown"),
    [(3.31964, "3.32"), (43.5, "43.5"), (1234.5, "1234"), (0.0255, "0.0255"), (1.6e-5, "1.60e-05")]
    + [(0, "0"), (None, "-"), ("error", "-"), (float("nan"), "-"), (True, "-")],
)
def test_numbers_keep_three_significant_digits(value, shown):
    assert fmt(value) == shown


def test_ratios_and_the_white_noise_fraction():
    assert ratio(3.0, 1.5) == "2.00x" and ratio(1.0, 0) == "-" and ratio(None, 1.0) == "-"
    assert WHITE_LOW_FREQUENCY == pytest.approx(0.0490874)


def test_copy_anchor_moves_each_jobs_bytes():
    figures = measure_copy(width=16, height=8, repeats=2, threads=1)
    for job, per_pixel in JOB_BYTES.items():
        assert figures[job]["bytes"] == 16 * 8 * per_pixel and figures[job]["copy_ms"] > 0
    assert set(PASS_JOBS.values()) == set(JOB_BYTES)
    assert figures["size"] == "16x8" and figures["threads"] == 1


def test_process_figures_ratio_each_round_to_mitsubas_process():
    from benchmarks.speed.process import _figures, table

    rounds = [
        {"cold": 8.0, "warm": 4.0, "eager": 6.0, "mitsuba_llvm": 2.0},
        {"cold": 9.0, "warm": 3.0, "eager": "exit code 1: boom", "mitsuba_llvm": 3.0},
    ]
    figures = _figures(rounds)
    assert figures["warm"] == {"best_s": 3.0, "median_s": 3.5, "runs": 2, "ratio_to_mitsuba": 1.5}
    assert figures["cold"]["ratio_to_mitsuba"] == pytest.approx(3.5)
    assert "ratio_to_mitsuba" not in figures["mitsuba_llvm"]
    assert figures["eager"]["runs"] == 1
    text = "\n".join(table({"processes": figures, "settings": {"scene": "cornell"}}, {}))
    assert (
        "| warm | 3.00 | 3.50 | 1.50x |" in text
        and "| mitsuba_llvm | 2.00 | 2.50 | anchor |" in text
    )
    missing = _figures([{"cold": 1.0, "mitsuba_llvm": "mitsuba is not installed"}])
    assert missing["mitsuba_llvm"] == {"error": "mitsuba is not installed"}
    assert "ratio_to_mitsuba" not in missing["cold"]
    assert "(mitsuba is not installed)" in "\n".join(table({"processes": missing}, {}))


def test_denoise_table_shows_each_goal_met_or_not():
    values = {"oidn": 1.0, "atrous": 0.4, "unet": 0.8, "gaussian": 0.1}
    text = "\n".join(denoise_table(values, {}))
    assert "| atrous | 0.400 | 2.50 | 0.400x | 0.500 s: yes |" in text
    assert "| unet | 0.800 | 1.25 | 0.800x | 0.700x OIDN: no |" in text
    assert "| gaussian | 0.100 | 10.0 | 0.100x | - |" in text
    assert goal_met("atrous", 0.6, None) == "0.500 s: no"  # an absolute goal needs no OIDN
    assert goal_met("unet", 0.5, None) == "0.700x OIDN: -"
    assert goal_met("unet", None, 1.0) == "0.700x OIDN: -"

"""``python -m benchmarks.reports DIR`` (benchmarks.reports.__main__), run as a process on a tiny
results folder: it rewrites every report from ``DIR/cells.jsonl`` and prints ``table.md``."""

from __future__ import annotations

import subprocess
import sys

from benchmarks.reports.table import markdown_table, summarize
from benchmarks.sweep.records import write_records
from tests._processes import child_env
from tests._records import small_record


def _records():
    out = []
    for strategy, value in (("white", 1.0), ("temporal", 0.8)):
        pairs = [
            [[value * 256.0 * (1 + 0.1 * f + 0.05 * s), 256.0] for f in range(2)] for s in range(2)
        ]
        metrics = {m: pairs for m in ("mse", "mse_blur1", "mse_blur2")}
        out.append(
            small_record(strategy, "gaussian", raw=metrics, den=metrics, frames=2, seed_sets=2)
        )
    return out


def test_the_module_rewrites_the_reports_of_a_folder_and_prints_its_table(tmp_path):
    folder = tmp_path / "tiny"
    folder.mkdir()
    write_records(folder, _records())
    done = subprocess.run(
        [sys.executable, "-m", "benchmarks.reports", str(folder)],
        cwd=tmp_path,
        env=child_env(),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    table = (folder / "table.md").read_text()
    assert done.stdout == table + "\n"
    assert table == markdown_table(summarize(_records()), "bnerr bench: tiny")
    assert "| spp | denoiser | white | temporal |" in table
    for name in ("table.csv", "decision.md", "index.html", "error_vs_time_direct.png"):
        assert (folder / name).is_file(), name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tiny"]  # nothing written beside it

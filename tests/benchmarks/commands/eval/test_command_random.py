"""``bnerr eval`` on random frame folders (issue 54, "Done when"): pixels drawn from finite values
of any magnitude from 1e-30 to 3e38 (either sign), NaN and infinities, and files cut at random
lengths. Each folder gives either a result or one line on the process's stderr (exit code 2),
never a traceback; a refusal leaves nothing behind (no results folder, no lock, no crop), and a
result leaves no temporary file."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmarks.cli import main
from benchmarks.commands.eval.frame_folder import frame_name
from bnerr.io import write_exr
from tests._frame_folders import synthetic_folder

pytestmark = pytest.mark.usefixtures("one_thread")

#: The files a random edit may hit: (method or "reference", seed set, frame).
_FILES = [("reference", "", t) for t in range(2)] + [
    (m, s, t) for m in ("white", "mine") for s in ("0", "1") for t in range(2)
]

_MAGNITUDE = st.floats(min_value=-30.0, max_value=math.log10(3e38))
_FINITE = st.builds(lambda e, sign: sign * 10.0**e, _MAGNITUDE, st.sampled_from([1.0, -1.0]))
_VALUE = st.one_of(_FINITE, st.sampled_from([math.nan, math.inf, -math.inf, 0.0]))


def _pixels(values: st.SearchStrategy[float]) -> st.SearchStrategy:
    return st.lists(
        st.tuples(st.integers(0, 2), st.integers(0, 7), st.integers(0, 7), values),
        min_size=1,
        max_size=6,
    )


_FINITE_EDIT = st.tuples(st.just("pixels"), st.sampled_from(_FILES), _pixels(_FINITE))
_EDIT = st.one_of(
    st.tuples(st.just("pixels"), st.sampled_from(_FILES), _pixels(_VALUE)),
    st.tuples(st.just("cut"), st.sampled_from(_FILES), st.floats(0.0, 0.999)),
)


def _path(root: Path, where: tuple[str, str, int]) -> Path:
    method, seed_set, t = where
    if method == "reference":
        return root / "reference" / frame_name(t)
    return root / method / seed_set / frame_name(t)


def _apply(root: Path, edit: tuple) -> None:
    kind, where, what = edit
    path = _path(root, where)
    if kind == "cut":
        data = path.read_bytes()
        path.write_bytes(data[: int(len(data) * what)])
        return
    y, x = torch.meshgrid(torch.linspace(0, 1, 8), torch.linspace(0, 1, 8), indexing="ij")
    color = (torch.stack([x, y, 0.5 * (x + y)]) + 0.2).numpy().astype(np.float32)
    with np.errstate(over="ignore"):
        for c, py, px, value in what:
            color[c, py, px] = np.float32(value)
    write_exr(path, {"color": torch.from_numpy(color)})


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> Path:
    return synthetic_folder(tmp_path_factory.mktemp("random") / "pristine")


def _eval(pristine: Path, tmp_path: Path, capfd, edits: list) -> tuple[int, str, Path]:
    """Copy the pristine folder, apply ``edits``, run ``bnerr eval`` in-process: its exit code,
    the process's stderr (file descriptor 2: OpenEXR's own lines too) and ``--out``."""
    root = tmp_path / "f"
    shutil.rmtree(root, ignore_errors=True)
    shutil.copytree(pristine, root)
    for edit in edits:
        _apply(root, edit)
    out = tmp_path / "out"
    shutil.rmtree(out, ignore_errors=True)
    capfd.readouterr()
    code = main(["eval", str(root), "--out", str(out), "--quiet", "--no-charts"])
    stdout, stderr = capfd.readouterr()
    assert "Traceback" not in stderr + stdout
    return code, stderr, out


def _a_result(out: Path) -> None:
    assert (out / "cells.jsonl").is_file() and (out / "table.md").is_file()
    assert not [p for p in out.rglob("*") if "bnerr-tmp" in p.name]


def _settings(examples: int) -> settings:
    return settings(
        max_examples=examples,
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.function_scoped_fixture],
    )


@_settings(8)
@given(edits=st.lists(_FINITE_EDIT, min_size=1, max_size=4))
def test_finite_values_of_any_magnitude_give_a_result(pristine, tmp_path, capfd, edits):
    """Any finite value a float32 EXR holds, 1e-30 to 3e38 either sign, in any frame or
    reference, is measured (issue 54: one of 1e24 ended in an OverflowError)."""
    code, stderr, out = _eval(pristine, tmp_path, capfd, edits)
    assert code == 0, stderr
    _a_result(out)


@_settings(12)
@given(edits=st.lists(_EDIT, min_size=1, max_size=3))
def test_a_random_folder_gives_a_result_or_one_line_and_leaves_nothing(
    pristine, tmp_path, capfd, edits
):
    code, stderr, out = _eval(pristine, tmp_path, capfd, edits)
    if code == 2:
        lines = stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("bnerr eval: error: "), stderr
        assert not out.exists(), sorted(p.name for p in out.rglob("*"))
    else:
        assert code == 0, stderr
        _a_result(out)

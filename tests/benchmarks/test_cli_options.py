"""Every numeric and path option of every ``bnerr`` command, tried with bad values from one table.

The options come from the parser itself (:func:`benchmarks.cli.build_parser`, walked with
argparse's API), so a new option is tried as soon as it exists; a numeric option is one whose
``type=`` is a number parser, a path option one whose ``type=`` is :class:`~pathlib.Path` or that
:data:`PATHS` names. Each is tried on the smallest valid command line of its command
(:data:`BASE`) at zero, a negative value, NaN, both infinities and an absurdly large value, and a
path option at a missing folder, a file where a folder is wanted and a folder where a file is.
Each case must end with exit code 2 and one error line, ``bnerr <command>: error: ...`` (a value
refused while parsing as well), or be listed in :data:`VALID` as a
documented valid result, which then must parse. Nothing may raise, and nothing may
start long work: every refusal happens before the command computes anything.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from benchmarks.cli import build_parser, main

HUGE = "1" + "0" * 30

#: The values each numeric option is tried at.
NUMBERS = {"zero": "0", "negative": "-1", "nan": "nan", "inf": "inf", "-inf": "-inf", "huge": HUGE}

#: The smallest valid command line of each command; ``{tmp}`` is the test's folder.
BASE = {
    "animate": [
        "animate", "--scene", "direct", "--strategies", "white", "--frames", "1", "--warmup", "0",
        "--res", "8x8", "--spp", "1", "--reference-spp", "1", "--gif-frames", "1", "--gif-crop",
        "8", "--out", "{tmp}/anim", "--cache", "{tmp}/cache",
    ],
    "bench": ["bench", "--suite", "quick", "--out", "{tmp}/bench", "--quiet", "--no-charts"],
    "denoise": ["denoise", "--denoiser", "box", "--in", "{tmp}/frame.exr", "--out", "{tmp}/o.exr"],
    "eval": ["eval", "{tmp}/no_frames", "--quiet", "--no-charts"],
    "export": ["export", "--fast", "--format", "npy", "--out", "{tmp}/x"],
    "mask": ["mask", "--size", "8", "--out", "{tmp}/m.npy"],
    "render": ["render", "--scene", "direct", "--res", "4x4", "--spp", "1", "--out", "{tmp}/r"],
    "retarget": ["retarget", "--size", "16", "--out", "{tmp}/r.npy"],
    "scenes": ["scenes"],
    "view": ["view", "{tmp}/no_results"],
    "train": [
        "train", "--out", "{tmp}/w.pt", "--scenes", "2", "--size", "8", "--reference-spp", "2",
        "--steps", "2", "--crop", "8", "--batch-size", "2", "--checkpoint-every", "2",
        "--no-progress",
    ],
}  # fmt: skip

#: Path options whose ``type=`` is not Path (a plain string), with what they name.
PATHS = {
    ("render", "--out"): "dir",
    ("train", "--out"): "file",
    ("denoise", "--in"): "file",
    ("denoise", "--out"): "file",
    ("denoise", "--tuned"): "file",
}
#: What the Path-typed options name (every other Path option is a file).
DIRS = {
    *(("animate", "--cache"), ("animate", "--out"), ("bench", "--cache"), ("bench", "--out")),
    ("eval", "--out"),
    ("export", "--out"),
}

#: Cases that are valid by design, each with why. They are parsed, not run: a valid value starts
#: the command's real work (a bench suite, a minute), which the test files of each command cover.
VALID = {
    ("render", "--start", "zero"): "frame index t = 0 is the first frame",
    ("render", "--seed", "zero"): "seed 0 is the default seed",
    ("render", "--exposure", "zero"): "0 stops: the radiance as rendered (the default)",
    ("render", "--exposure", "negative"): "-1 stop: a darker preview",
    ("mask", "--seed", "zero"): "seed 0 is the default seed",
    ("retarget", "--seed", "zero"): "seed 0 is the default seed",
    ("retarget", "--iterations", "zero"): "exact method ignores it; annealing does no step",
    ("retarget", "--radius", "zero"): "radius 0: the identity field",
    ("retarget", "--temperature", "zero"): "temperature 0: greedy annealing (exact ignores it)",
    ("train", "--seed", "zero"): "seed 0 is the default seed",
    ("render", "--out", "missing"): "the output folder is created, parents included",
    ("mask", "--out", "missing"): "the output file's folder is created",
    ("retarget", "--out", "missing"): "the output file's folder is created",
    ("train", "--out", "missing"): "the output file's folder is created",
    ("animate", "--warmup", "zero"): "no frames rendered before the shown ones",
    ("animate", "--seed-set", "zero"): "seed set 0 is the default",
    ("animate", "--gif-frames", "zero"): "0: every frame in the GIF (its help says so)",
    ("animate", "--cache", "missing"): "the cache folder is created, parents included",
    ("animate", "--cache", "dir_for_file"): "a folder named *.exr is still a folder",
    ("animate", "--out", "missing"): "the output folder is created, parents included",
    ("animate", "--out", "dir_for_file"): "a folder named *.exr is still a folder",
    ("bench", "--warmup", "zero"): "no frames rendered before the measured ones",
    ("bench", "--out", "missing"): "the output folder is created, parents included",
    ("export", "--out", "missing"): "the output folder is created, parents included",
    ("export", "--out", "dir_for_file"): "a folder named *.exr is still a folder",
    ("bench", "--out", "dir_for_file"): "a folder named *.exr is still a folder",
    ("bench", "--cache", "missing"): "the cache folder is created, parents included",
    ("bench", "--cache", "dir_for_file"): "a folder named *.exr is still a folder",
    ("view", "--port", "zero"): "port 0: any free port (its help says so)",
}


def _options() -> list[tuple[str, str, str]]:
    """(command, flag, kind) of every numeric or path option: kind is int, float, dir or file."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    found = []
    for command, subparser in sorted(sub.choices.items()):
        for action in subparser._actions:
            flag = next((s for s in action.option_strings if s.startswith("--")), None)
            if flag is None or action.nargs == 0:
                continue
            kind = _kind(command, flag, action)
            if kind is not None:
                found.append((command, flag, kind))
    return found


def _kind(command: str, flag: str, action: argparse.Action) -> str | None:
    if (command, flag) in PATHS:
        return PATHS[(command, flag)]
    if action.type is Path:
        return "dir" if (command, flag) in DIRS else "file"
    if action.type is None or action.choices is not None:
        return None
    probe = action.type("1")  # a number parser takes "1"
    return "int" if isinstance(probe, int) else "float" if isinstance(probe, float) else None


OPTIONS = _options()


def _cases() -> list[tuple[str, str, str]]:
    cases = []
    for command, flag, kind in OPTIONS:
        names = NUMBERS if kind in ("int", "float") else ("missing", "file_for_dir", "dir_for_file")
        cases += [(command, flag, name) for name in names]
    return cases


def _path_value(tmp: Path, kind: str, name: str) -> str | None:
    """The bad path of case ``name`` for an option naming a ``kind``, or None if not applicable."""
    a_file = tmp / "a_file.txt"
    a_file.write_text("not a folder\n")
    (tmp / "a_dir.npy").mkdir(exist_ok=True)
    (tmp / "a_dir.exr").mkdir(exist_ok=True)
    if name == "missing":  # a path under a folder that does not exist
        return str(tmp / "missing" / "sub" / ("out" if kind == "dir" else "x.npy"))
    if name == "file_for_dir":  # an existing file where a folder is wanted, or inside the path
        return str(a_file) if kind == "dir" else str(a_file / "x.npy")
    return str(tmp / ("a_dir.npy" if kind == "file" else "a_dir.exr"))  # a folder


def _argv(command: str, flag: str, value: str, tmp: Path) -> list[str]:
    base = [arg.replace("{tmp}", str(tmp)) for arg in BASE[command]]
    if flag in base:  # the case's value replaces the base line's
        i = base.index(flag)
        return [*base[:i], *base[i + 2 :], flag, value]
    return [*base, flag, value]


def test_every_option_of_every_command_is_in_the_table():
    commands = {command for command, _, _ in OPTIONS}
    assert commands <= set(BASE), f"no base command line for {sorted(commands - set(BASE))}"
    assert len(OPTIONS) >= 50  # the walk found the options (not an empty parser)
    for command, flag, _case in VALID:
        assert any(c == command and f == flag for c, f, _ in OPTIONS), (command, flag)


@pytest.mark.parametrize(("command", "flag", "case"), _cases(), ids=lambda part: part)
def test_option_value_is_an_error_or_a_documented_result(
    command, flag, case, tmp_path, capsys, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    kind = next(k for c, f, k in OPTIONS if (c, f) == (command, flag))
    value = NUMBERS[case] if case in NUMBERS else _path_value(tmp_path, kind, case)
    argv = _argv(command, flag, value, tmp_path)
    if (command, flag, case) in VALID:  # parsed, not run: a valid value may start long work
        build_parser(command).parse_args(argv)
        return
    if command == "denoise":
        _frame(tmp_path)
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, f"{argv}: expected exit code 2, got {code}"
    assert err.count("\n") == 1 and err.startswith(f"bnerr {command}: error: "), err
    assert "Traceback" not in err


def _frame(tmp: Path) -> None:
    """The tiny frame ``BASE['denoise']`` reads, rendered once per test folder."""
    if not (tmp / "frame.exr").exists():
        assert main(["render", "--scene", "direct", "--res", "4x4", "--spp", "1"]
                    + ["--out", str(tmp / "render")]) == 0  # fmt: skip
        next((tmp / "render").glob("*.exr")).rename(tmp / "frame.exr")

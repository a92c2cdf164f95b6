"""Issue 28, item 4: every missing optional extra is one MissingExtraError naming the extra and
its install command, and the CLI prints it as one line with exit code 2."""

import builtins
import importlib.util
import pickle

import pytest

from benchmarks.cli import main
from bnerr.errors import EXTRAS, BnerrError, MissingExtraError


def _hide(monkeypatch, *modules):
    """Make ``import <module>`` and ``find_spec(<module>)`` fail for each of ``modules``."""
    real_import, real_find = builtins.__import__, importlib.util.find_spec

    def fake_import(name, *args, **kwargs):
        if name.split(".")[0] in modules:
            raise ModuleNotFoundError(f"No module named '{name}'")
        return real_import(name, *args, **kwargs)

    def fake_find(name, *args, **kwargs):
        return None if name.split(".")[0] in modules else real_find(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake_import)
    monkeypatch.setattr(importlib.util, "find_spec", fake_find)
    for module in modules:
        monkeypatch.setitem(__import__("sys").modules, module, None)


def _check(err, extra):
    assert isinstance(err, MissingExtraError)
    assert isinstance(err, BnerrError) and isinstance(err, ImportError)
    assert err.extra == extra and err.install == EXTRAS[extra]
    assert f"optional extra '{extra}'" in str(err) and EXTRAS[extra] in str(err)
    assert "\n" not in str(err)


def test_the_message_names_the_extra_and_its_install_command_and_survives_pickling():
    err = MissingExtraError("oidn", "reference", "pyoidn", "nothing")
    _check(err, "reference")
    assert "pip install '.[reference]'" in str(err)
    back = pickle.loads(pickle.dumps(err))
    _check(back, "reference")
    assert str(back) == str(err)
    with pytest.raises(BnerrError, match="unknown optional extra 'nope'"):
        MissingExtraError("x", "nope", "y", "z")


def test_oidn(monkeypatch):
    from denoisers.oidn import load_pyoidn

    _hide(monkeypatch, "pyoidn")
    with pytest.raises(MissingExtraError) as info:
        load_pyoidn()
    _check(info.value, "reference")
    assert "pyoidn" in str(info.value)


def test_flip(monkeypatch):
    from bnerr.metrics.image import require_flip

    _hide(monkeypatch, "flip_evaluator")
    with pytest.raises(MissingExtraError) as info:
        require_flip()
    _check(info.value, "reference")
    assert "flip-evaluator" in str(info.value)


def test_mitsuba_both_modules(monkeypatch):
    import renderers.mitsuba as mitsuba
    import renderers.mitsuba_render as mitsuba_render

    _hide(monkeypatch, "mitsuba")
    for call in (mitsuba._mi, mitsuba_render.load_mitsuba):
        with pytest.raises(MissingExtraError) as info:
            call()
        _check(info.value, "reference")
        assert "mitsuba==3.9.1" in str(info.value)


def test_mitsuba_llvm_library():
    from renderers.mitsuba_render import _check_llvm

    class NoLLVM:
        class detail:  # mimics drjit.detail
            @staticmethod
            def llvm_version():
                raise RuntimeError("could not find libLLVM")

    class OldLLVM:
        class detail:
            @staticmethod
            def llvm_version():
                return (15, 0, 7)

    for dr in (NoLLVM, OldLLVM):
        with pytest.raises(MissingExtraError) as info:
            _check_llvm(dr)
        _check(info.value, "llvm")
        assert "libllvm19" in str(info.value)


def test_ray(monkeypatch):
    from benchmarks.sweep.ray_runner import require_ray

    _hide(monkeypatch, "ray")
    with pytest.raises(MissingExtraError) as info:
        require_ray()
    _check(info.value, "cluster")
    assert "pip install '.[cluster]'" in str(info.value)


def test_ffmpeg(monkeypatch):
    from benchmarks.animate import require_ffmpeg

    _hide(monkeypatch, "imageio_ffmpeg")
    with pytest.raises(MissingExtraError) as info:
        require_ffmpeg()
    _check(info.value, "ffmpeg")
    assert "imageio-ffmpeg" in str(info.value)


def _one_line_exit_2(capsys, code, extra):
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert f"optional extra '{extra}'" in err and EXTRAS[extra] in err
    assert "Traceback" not in err


def test_cli_prints_a_missing_oidn_as_one_line(tmp_path, capsys, monkeypatch):
    import torch

    from bnerr.frame import Frame
    from bnerr.io import write_frame

    path = tmp_path / "f.exr"
    g = torch.Generator().manual_seed(0)
    write_frame(path, Frame(color=torch.rand(3, 4, 4, generator=g)))
    _hide(monkeypatch, "pyoidn")
    args = ["denoise", "--denoiser", "oidn", "--in", str(path), "--out", str(tmp_path / "o.exr")]
    _one_line_exit_2(capsys, main(args), "reference")
    assert not (tmp_path / "o.exr").exists()


def test_cli_prints_a_missing_ffmpeg_as_one_line_before_rendering(tmp_path, capsys, monkeypatch):
    _hide(monkeypatch, "imageio_ffmpeg")
    code = main(["animate", "--scene", "direct", "--frames", "2", "--out", str(tmp_path / "a")])
    _one_line_exit_2(capsys, code, "ffmpeg")

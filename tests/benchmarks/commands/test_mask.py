"""``bnerr mask``: writes the mask it reports, in every format, and rejects bad arguments."""

import numpy as np
import pytest

from benchmarks.cli import main
from bnerr.io import read_exr
from bnerr.masks import void_and_cluster


def test_npy_holds_the_generated_mask_and_the_report_names_the_fraction(tmp_path, capsys):
    out = tmp_path / "m.npy"
    assert main(["mask", "--size", "16", "--seed", "3", "--out", str(out)]) == 0
    saved = np.load(out)
    assert np.array_equal(saved, void_and_cluster(16, seed=3).numpy())
    printed = capsys.readouterr().out
    assert "low-frequency fraction" in printed and " s -> " in printed


def test_exr_round_trips_a_vector_mask(tmp_path):
    out = tmp_path / "v.exr"
    assert (
        main(["mask", "--size", "16", "--dims", "2", "--iterations", "2", "--out", str(out)]) == 0
    )
    mask = read_exr(out)["mask"]
    assert mask.shape == (2, 16, 16)
    for channel in mask:  # swaps of whole vectors keep each channel a permutation of (k+0.5)/N
        assert np.allclose(np.sort(channel.numpy().ravel()), (np.arange(256) + 0.5) / 256)


def test_png_stores_the_mask_values_as_8_bit(tmp_path):
    from skimage.io import imread

    out = tmp_path / "m.png"
    assert main(["mask", "--size", "16", "--out", str(out)]) == 0
    stored = imread(out)[..., 0].astype(np.float64)
    expected = np.round(255 * void_and_cluster(16).numpy().astype(np.float64))
    assert np.abs(stored - expected).max() <= 1


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--size", "16", "--out", "m.tiff"], "expected a name ending in .npy or .exr or .png"),
        (["--size", "-4", "--out", "m.npy"], "size"),
    ],
)
def test_bad_arguments_exit_2_with_a_message(tmp_path, capsys, argv, message):
    argv = [a if not a.startswith("m.") else str(tmp_path / a) for a in argv]
    assert main(["mask", *argv]) == 2
    assert message in capsys.readouterr().err


def test_fast_anneals_the_void_and_cluster_mask_and_reports_both_energies(tmp_path, capsys):
    from bnerr.masks.fast import fast_mask

    out = tmp_path / "f.npy"
    argv = ["mask", "--size", "16", "--seed", "2", "--fast", "0.5", "--iterations", "4"]
    assert main([*argv, "--out", str(out)]) == 0
    want = fast_mask(16, 0.5, seed=2, iterations=4, start=void_and_cluster(16, seed=2))
    assert np.array_equal(np.load(out), want.numpy())
    printed = capsys.readouterr().out
    assert "FAST energy" in printed and "void-and-cluster start" in printed
    assert "low-frequency fraction" in printed


# ---- spatiotemporal masks (--frames) ------------------------------------------------------------


def test_frames_writes_the_scalar_stbn_and_reports_both_fractions(tmp_path, capsys):
    from bnerr.masks.stbn import stbn_scalar

    out = tmp_path / "st.npy"
    argv = ["mask", "--size", "8", "--frames", "3", "--seed", "2", "--threads", "1"]
    assert main([*argv, "--out", str(out)]) == 0
    saved = np.load(out)
    assert saved.dtype == np.float32 and saved.shape == (3, 8, 8)
    assert np.array_equal(saved, stbn_scalar(8, 3, seed=2).numpy())
    printed = capsys.readouterr().out
    assert "per slice: max" in printed and "temporal low-frequency fraction" in printed
    assert not [p for p in tmp_path.iterdir() if p.name != "st.npy"]  # no temporary left


def test_frames_with_dims_writes_the_vector_stbn(tmp_path):
    from bnerr.masks.stbn import stbn_vector

    out = tmp_path / "v.npy"
    argv = ["mask", "--size", "12", "--frames", "2", "--dims", "2", "--iterations", "1"]
    assert main([*argv, "--sigma", "1.5", "--out", str(out)]) == 0
    want = stbn_vector(12, 2, 2, seed=0, sigma=1.5, iterations=1)
    assert np.array_equal(np.load(out), want.numpy())


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--frames", "2", "--out", "m.exr"], "expected a .npy file for a spatiotemporal mask"),
        (["--frames", "0", "--out", "m.npy"], "--frames: expected an integer >= 1"),
        (["--frames", "2", "--size", "1", "--out", "m.npy"], "--size: expected an integer >= 2"),
        (["--frames", "2", "--out", "file.txt/m.npy"], "file.txt"),
        (["--out", "file.txt/m.npy"], "file.txt"),
        (["--frames", "2", "--threads", "0", "--out", "m.npy"], "--threads"),
        (["--fast", "0.5", "--dims", "2", "--out", "m.npy"], "--fast: expected a scalar 2D mask"),
        (["--fast", "0.5", "--frames", "2", "--out", "m.npy"], "--fast: expected a scalar"),
        (["--fast", "0.5", "--out", "file.txt/m.npy"], "file.txt"),
        (["--joint", "--out", "m.npy"], "--joint: expected only with --ldbn"),
    ],
)
def test_frames_output_and_arguments_are_checked_before_generating(
    tmp_path, capsys, monkeypatch, argv, message
):
    import benchmarks.commands.mask as command

    def never(*args, **kwargs):
        raise AssertionError("generated before the arguments were checked")

    for name in ("stbn_scalar", "stbn_vector", "void_and_cluster", "vector_mask", "fast_mask"):
        monkeypatch.setattr(command, name, never)
    (tmp_path / "file.txt").write_text("not a folder")
    argv = [str(tmp_path / a) if a.startswith(("m.", "file.txt")) else a for a in argv]
    assert main(["mask", *argv]) == 2
    assert message in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt"]


def test_ldbn_writes_the_keys_it_optimized_and_removes_its_checkpoint(tmp_path, capsys):
    from bnerr.ldbn.keys import KeyOptions, optimize_keys

    out = tmp_path / "k.npy"
    argv = ["mask", "--ldbn", "--size", "8", "--spp", "2", "--dims", "2", "--iterations", "3"]
    assert main([*argv, "--out", str(out)]) == 0
    saved = np.load(out)
    scramble, rank = optimize_keys(KeyOptions(size=8, levels=2, dims=2, iterations=3))
    assert np.array_equal(saved, np.concatenate([scramble, rank], -1))
    assert not (tmp_path / "k.ckpt.npz").exists()
    printed = capsys.readouterr().out
    assert "LDBN keys 8x8x1, spp 1..2, D=2" in printed and "sigma-2 blur keeps" in printed


def test_ldbn_joint_writes_the_joint_keys(tmp_path, capsys):
    from bnerr.ldbn.keys import KeyOptions, optimize_keys

    out = tmp_path / "k.npy"
    argv = ["mask", "--ldbn", "--joint", "--size", "8", "--spp", "2", "--dims", "4"]
    assert main([*argv, "--iterations", "3", "--out", str(out)]) == 0
    opts = KeyOptions(size=8, levels=2, dims=4, iterations=3, joint=True)
    scramble, rank = optimize_keys(opts)
    assert np.array_equal(np.load(out), np.concatenate([scramble, rank], -1))
    assert "D=4, joint" in capsys.readouterr().out


def test_ldbn_base_writes_keys_over_that_base(tmp_path, capsys):
    from bnerr.ldbn.keys import KeyOptions, optimize_keys

    out = tmp_path / "k.npy"
    argv = ["mask", "--ldbn", "--base", "zorder", "--size", "8", "--spp", "4", "--dims", "2"]
    assert main([*argv, "--iterations", "3", "--out", str(out)]) == 0
    opts = KeyOptions(size=8, levels=3, dims=2, iterations=3, base="zorder")
    scramble, rank = optimize_keys(opts)
    assert np.array_equal(np.load(out), np.concatenate([scramble, rank], -1))
    assert "D=2, base zorder" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--base", "lattice", "--frames", "2"], "screen tile"),
        (["--base", "zorder", "--size", "6"], "power of two"),
        (["--spp", "3"], "power of two"),
        (["--dims", "3"], "even"),
        (["--out-png"], ".npy"),
        (["--device", "gpu0"], "torch device"),
    ],
)
def test_ldbn_refuses_bad_arguments(tmp_path, capsys, argv, message):
    out = tmp_path / ("k.png" if argv == ["--out-png"] else "k.npy")
    argv = [] if argv == ["--out-png"] else argv
    assert main(["mask", "--ldbn", "--size", "8", *argv, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err

"""Tests of the denoisers package: the registry (denoisers/__init__.py), the interface (base.py)."""

import pytest
import torch

import denoisers
from bnerr.errors import DtypeError, NonFiniteError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.frame import Frame
from denoisers import DENOISERS, Denoiser, MissingBufferError, check_frame, get_denoiser
from tests._images import random_frame
from tests._paths import EXAMPLES

NAMES = [
    "atrous",
    "bilateral",
    "cycles_oidn",
    "gaussian",
    "guided",
    "joint_bilateral",
    "median",
    "oidn",
    "svgf",
    "taa",
    "unet",
    "unet_blue",
]
STATEFUL = {"svgf", "taa"}


def test_registry_names_sorted_and_complete():
    assert list(DENOISERS) == NAMES
    assert denoisers.__all__ == sorted(denoisers.__all__)
    for name, cls in DENOISERS.items():
        assert cls.name == name and issubclass(cls, Denoiser)
        assert cls.stateful == (name in STATEFUL)


@pytest.mark.parametrize("name", NAMES)
def test_every_denoiser_takes_reset_and_a_frame_index(name):
    """Callers treat all denoisers alike: reset, then frames in order with their index t."""
    frames = [random_frame(seed=s) for s in range(3)]
    denoiser = get_denoiser(name)
    first = [denoiser(f, t=t) for t, f in enumerate(frames)]
    denoiser.reset()
    again = [denoiser(f, t=t) for t, f in enumerate(frames)]
    assert all(torch.equal(a, b) for a, b in zip(first, again, strict=True))
    if not denoiser.stateful:  # stateless: the index and the order change nothing
        assert torch.equal(denoiser(frames[1]), first[1])
        assert torch.equal(denoiser(frames[2], t=7), first[2])
    with pytest.raises(DtypeError, match=f"denoiser '{name}': t: expected an int frame index"):
        denoiser(frames[0], t=1.0)


@pytest.mark.parametrize("name", NAMES)
def test_every_denoiser_maps_frame_to_color(name):
    frame = random_frame()
    out = get_denoiser(name)(frame)
    assert (
        out.shape == (3, 12, 10) and out.dtype == torch.float32 and out.device == frame.color.device
    )
    assert torch.isfinite(out).all()


def test_unknown_name_and_parameter_raise():
    with pytest.raises(UnknownNameError, match="unknown denoiser 'box'"):
        get_denoiser("box")
    with pytest.raises(UnknownNameError, match="unknown parameter.*radius.*expected one of sigma"):
        get_denoiser("gaussian", radius=3)


@pytest.mark.parametrize(
    "name, missing",
    [
        ("joint_bilateral", "albedo"),
        ("guided", "normal"),
        ("atrous", "depth"),
        ("unet", "albedo"),
        ("oidn", "normal"),
        ("taa", "motion"),
        ("svgf", "object_id"),
    ],
)
def test_missing_buffer_is_named(name, missing):
    frame = random_frame(drop=(missing,))
    with pytest.raises(MissingBufferError, match=f"denoiser '{name}'.*without {missing}"):
        get_denoiser(name)(frame)


def test_colour_only_filters_need_no_aux_buffers():
    frame = Frame(color=torch.rand(3, 9, 9, generator=torch.Generator().manual_seed(3)))
    for name in ("gaussian", "bilateral", "median"):
        assert get_denoiser(name)(frame).shape == (3, 9, 9)


def test_bad_frames_raise_typed_errors():
    with pytest.raises(DtypeError, match="expected a bnerr.frame.Frame, got Tensor"):
        get_denoiser("gaussian")(torch.rand(3, 8, 8))
    frame = random_frame()
    frame.albedo = torch.rand(3, 5, 5)  # assigned after construction: Frame could not check it
    with pytest.raises(ShapeError, match=r"frame.albedo: expected shape \[3, 12, 10\]"):
        get_denoiser("guided")(frame)
    frame = random_frame()
    frame.color[0, 1, 1] = float("nan")
    with pytest.raises(NonFiniteError, match="frame.color: expected finite values, got 1 NaN"):
        get_denoiser("median")(frame)


def test_check_frame_returns_frame_and_lists_all_missing():
    frame = random_frame(drop=("albedo", "depth"))
    assert check_frame(frame, frozenset({"normal"}), "x") is frame
    with pytest.raises(MissingBufferError, match="without albedo, depth"):
        check_frame(frame, frozenset({"albedo", "depth", "normal"}), "x")


def test_bad_parameter_values_raise():
    with pytest.raises(
        ValueRangeError, match=r"gaussian: sigma: expected a value in \[0.1, 16.0\], got -1"
    ):
        get_denoiser("gaussian", sigma=-1)
    with pytest.raises(DtypeError, match="median: kernel_size: expected an integer"):
        get_denoiser("median", kernel_size=3.0)
    with pytest.raises(
        ValueRangeError, match="median: kernel_size: expected an odd integer, got 4"
    ):
        get_denoiser("median", kernel_size=4)
    with pytest.raises(UnknownNameError, match="unknown oidn quality 'ultra'"):
        get_denoiser("oidn", quality="ultra")


def test_subclass_breaking_the_contract_is_caught():
    class Broken(Denoiser):
        name = "broken"

        def denoise(self, frame):
            return frame.color[:1]

    with pytest.raises(ShapeError, match="denoiser 'broken' output"):
        Broken()(random_frame())


# -- every buffer a denoiser reads is checked; the output is never NaN (issue 18) -----------------


@pytest.mark.parametrize(
    ("name", "buffer"),
    [
        ("unet", "normal"),  # 16 NaN normals made every output value NaN, exit 0
        ("unet", "albedo"),
        ("joint_bilateral", "normal"),
        ("joint_bilateral", "albedo"),
        ("guided", "normal"),
        ("guided", "albedo"),
        ("atrous", "normal"),
        ("atrous", "depth"),
    ],
)
def test_a_nan_guide_is_refused_naming_the_buffer_count_and_pixel(name, buffer):
    frame = random_frame()
    values = getattr(frame, buffer)
    values[:, 3, 4] = float("nan")
    values[:, 7, 1] = float("nan")
    with pytest.raises(
        NonFiniteError,
        match=rf"denoiser '{name}': frame.{buffer}: expected finite values, got "
        rf"{2 * values.shape[0]} NaN and 0 infinite of \d+, first at pixel \(y, x\) = \(3, 4\)",
    ):
        get_denoiser(name)(frame)


def test_minus_infinite_depth_is_refused_but_plus_infinite_is_background():
    frame = random_frame()
    frame.depth[0, 2, 2] = -float("inf")
    with pytest.raises(
        NonFiniteError, match="frame.depth: expected finite values, got 0 NaN and 1"
    ):
        get_denoiser("atrous")(frame)


@pytest.mark.parametrize("name", ["gaussian", "bilateral", "joint_bilateral", "guided", "median"])
def test_buffers_a_denoiser_does_not_read_are_not_checked(name):
    frame = random_frame()
    frame.depth[0, 0, 0] = float("nan")
    assert torch.isfinite(get_denoiser(name)(frame)).all()


def test_a_denoiser_that_returns_nan_is_caught_at_the_boundary():
    class Broken(Denoiser):
        name = "broken"

        def denoise(self, frame):
            out = frame.color.clone()
            out[1, 5, 6] = float("nan")
            return out

    with pytest.raises(
        NonFiniteError, match=r"denoiser 'broken' output \(finite input\): .* \(y, x\) = \(5, 6\)"
    ):
        Broken()(random_frame())


def test_a_manifest_loaded_again_is_the_same_registered_class(forget):
    manifest = str(EXAMPLES / "external_denoiser" / "manifest.toml")
    forget.append(("bnerr.denoisers", "example_joint_bilateral"))
    name = denoisers.load_denoiser(manifest)
    cls = DENOISERS[name]
    assert denoisers.load_denoiser(manifest) == name  # a worker loads the parts' specs again
    assert DENOISERS[name] is cls


def test_a_manifests_fingerprint_follows_the_program_it_runs(tmp_path, forget):
    """Issue 54: ``--resume`` did not see an edited program behind an unchanged manifest (the
    fingerprint hashed the manifest alone); it hashes the program file the command runs too."""
    import shutil

    from bnerr import plugins

    folder = tmp_path / "ext"
    shutil.copytree(EXAMPLES / "external_denoiser", folder)
    manifest = folder / "manifest.toml"
    forget.append(("bnerr.denoisers", "example_joint_bilateral"))
    name = denoisers.load_denoiser(str(manifest))
    plugin = plugins.loaded("bnerr.denoisers", name)
    assert plugin.files == (str(manifest.resolve()), str((folder / "denoise.py").resolve()))
    before = plugin.fingerprint
    with (folder / "denoise.py").open("a") as script:
        script.write("\n# an edit that changes what runs\n")
    assert plugin.fingerprint != before and plugin.fingerprint.startswith("sha256:")
    assert denoisers.load_denoiser(str(manifest)) == name  # still found by its manifest

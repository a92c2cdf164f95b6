"""Tests of denoisers/unet.py: the network, its input transform, its weights files."""

import functools

import pytest
import torch

from bnerr.errors import DtypeError, FileFormatError, ShapeError, ValueRangeError
from bnerr.metrics import paired_ratio
from denoisers import DENOISERS, get_denoiser
from denoisers import unet as unet_module
from denoisers.tuning import GRIDS, tune
from denoisers.unet import (
    DEFAULT_WEIGHTS,
    DEFAULT_WIDTHS,
    MAX_PARAMETERS,
    FastUNet,
    UNet,
    UNetDenoiser,
    auto_exposure,
    conv_into,
    load_weights,
    network_input,
    parameter_count,
    sanitized,
    save_weights,
    unet_denoise,
    upsampled_transpose_kernel,
)
from tests._images import random_frame
from tests._scene_renders import SCENES, measured_frames, mse, scene_renders


def test_default_network_is_within_the_parameter_cap():
    assert parameter_count(DEFAULT_WIDTHS) <= MAX_PARAMETERS


@pytest.mark.parametrize("h, w", [(8, 8), (13, 29), (1, 1)])
def test_any_size_maps_to_same_size(h, w):
    torch.manual_seed(0)
    net = UNet((4, 4, 4, 4)).eval()
    x = torch.rand(2, 9, h, w)
    assert net(x).shape == (2, 3, h, w)


def test_network_is_local_with_skips_concatenated():
    # A change of one input pixel must change the output near it (the full-resolution skip) and
    # leave far pixels alone (the receptive field is bounded).
    torch.manual_seed(0)
    net = UNet((4, 4, 4, 4)).eval()
    x = torch.rand(1, 9, 96, 96)
    y = x.clone()
    y[0, :, 4, 4] += 1.0
    with torch.no_grad():
        diff = (net(x) - net(y)).abs()[0].sum(0)
    assert float(diff[4, 4]) > 0 and float(diff[80:, 80:].max()) == 0.0


def test_auto_exposure_makes_the_input_scale_invariant():
    frame = random_frame(20, 28)
    bright = random_frame(20, 28, scale=40.0)
    e, e_bright = auto_exposure(frame.color), auto_exposure(bright.color)
    torch.testing.assert_close(e / e_bright, torch.tensor(40.0), rtol=1e-5, atol=0)
    a = network_input(frame.color, frame.albedo, frame.normal, e)
    b = network_input(bright.color, bright.albedo, bright.normal, e_bright)
    torch.testing.assert_close(a, b, rtol=1e-5, atol=1e-6)
    assert float(auto_exposure(torch.zeros(3, 4, 4))) == 1.0


def test_inputs_out_of_range_are_sanitized_as_oidn_does():
    # A renderer's denoising albedo can exceed 1 (Cycles' does on glossy highlights, up to 154)
    # and a pass can hold NaN: the network sees what OIDN's input stage would give it.
    torch.manual_seed(0)
    net = UNet((4, 6, 8, 8)).eval()
    frame = random_frame(20, 28)
    albedo, normal, color = frame.albedo.clone(), frame.normal.clone(), frame.color.clone()
    albedo[:, 3, 5], albedo[:, 7, 9] = 154.0, float("nan")
    normal[:, 2, 2], color[:, 4, 4] = -3.0, float("nan")
    before = (albedo.clone(), normal.clone(), color.clone())
    clean = sanitized(color, albedo, normal)
    assert float(clean[1].max()) <= 1.0 and float(clean[2].min()) >= -1.0
    assert all(bool(t.isfinite().all()) for t in clean)
    out = unet_denoise(net, color, albedo, normal)
    assert bool(out.isfinite().all())
    assert torch.equal(out, unet_denoise(net, *clean))
    # in range, nothing changes; the caller's tensors are left as they were
    assert torch.equal(
        network_input(frame.color, frame.albedo, frame.normal, torch.tensor(2.0)),
        torch.cat([torch.log1p(frame.color * 2.0), frame.albedo, frame.normal]),
    )
    for kept, now in zip(before, (albedo, normal, color), strict=True):
        assert torch.equal(kept.nan_to_num(nan=-7.0), now.nan_to_num(nan=-7.0))


def test_save_load_and_denoise_round_trip(tmp_path):
    torch.manual_seed(0)
    net = UNet((4, 6, 8, 8)).eval()
    save_weights(net, tmp_path / "w.pt", meta={"command": "test"})
    loaded = load_weights(tmp_path / "w.pt")
    assert loaded.widths == (4, 6, 8, 8)
    frame = random_frame(20, 28)
    expected = unet_denoise(net, frame.color, frame.albedo, frame.normal)
    assert torch.equal(unet_denoise(loaded, frame.color, frame.albedo, frame.normal), expected)
    out = UNetDenoiser(weights=tmp_path / "w.pt")(frame)
    # The denoiser runs a channels-last copy: equal within float32 summation order (see below).
    torch.testing.assert_close(out, expected, rtol=1e-4, atol=1e-5)
    assert bool((out >= 0).all())
    assert UNetDenoiser(weights=str(tmp_path / "w.pt")).params() == {
        "weights": str(tmp_path / "w.pt")
    }


def test_bad_weights_raise(tmp_path):
    with pytest.raises(
        FileFormatError, match="nope.pt: expected a U-Net weights file, got no such file"
    ):
        load_weights(tmp_path / "nope.pt")
    (tmp_path / "junk.pt").write_bytes(b"\x00garbage")
    with pytest.raises(
        FileFormatError, match="junk.pt: expected a U-Net weights file, got an unreadable file"
    ):
        UNetDenoiser(weights=tmp_path / "junk.pt")
    torch.save(
        {
            "format": "bnerr-unet-weights-v1",
            "widths": [4, 4, 4, 4],
            "residual": True,
            "state_dict": {},
        },
        tmp_path / "e.pt",
    )
    with pytest.raises(
        FileFormatError, match="e.pt: expected U-Net widths, residual flag and weights, got"
    ):
        load_weights(tmp_path / "e.pt")
    torch.save({"format": "bnerr-unet-weights-v1", "widths": [4, 4, 4, 4]}, tmp_path / "k.pt")
    with pytest.raises(FileFormatError, match="KeyError"):
        load_weights(tmp_path / "k.pt")
    torch.save([1, 2], tmp_path / "l.pt")
    with pytest.raises(
        FileFormatError, match="expected format 'bnerr-unet-weights-v1', got 'list'"
    ):
        load_weights(tmp_path / "l.pt")
    with pytest.raises(DtypeError, match="unet: weights: expected a path, got int"):
        UNetDenoiser(weights=3)
    with pytest.raises(ValueRangeError, match="UNet: widths: expected 4 positive integers"):
        UNet((4, 4, 4))


# ------------------------------------------------------------------------------------------------
# The shipped weights, on the benchmark's scenes (all held out from training).


def test_shipped_weights_load_and_record_their_command():
    payload = torch.load(DEFAULT_WEIGHTS, weights_only=True)
    command = payload["meta"]["command"]
    assert payload["meta"]["finished"] and command.startswith("bnerr train ")
    readme = (DEFAULT_WEIGHTS.parent / "README.md").read_text()
    assert f"`{command}`" in readme or f"\n{command}\n" in readme
    assert parameter_count(UNetDenoiser().model.widths) <= MAX_PARAMETERS


@pytest.mark.parametrize("scene", SCENES)
def test_unet_lowers_mse_on_every_scene_at_4spp(scene):
    _, frame, reference = scene_renders(scene)
    assert mse(UNetDenoiser()(frame), reference) < mse(frame.color, reference)


#: Per-pixel samplers the held-out comparison runs with: independent samples, and the
#: Owen-scrambled Sobol sequences every strategy of the benchmark renders with (and that the
#: shipped weights were trained on).
SAMPLERS = ("white", "owen_sobol")

#: The level of the held-out comparison's interval: 95 % for the family of every scene and
#: sampler (Bonferroni over the len(SCENES) x len(SAMPLERS) = 12 comparisons the claim "beyond the
#: interval" is made for at once).
LEVEL = 1 - 0.05 / (len(SCENES) * len(SAMPLERS))

#: Comparisons measured not to hold at this test's size (64 x 64, 4 spp, eight frames), with why.
#: Each is a strict xfail, so the suite says so as soon as one starts to hold.
_NOT_BELOW_ONE = {
    ("cornell", "owen_sobol"): (
        "measured: U-Net / joint bilateral = 1.089 [0.632, 1.877] (t-interval over the eight "
        "frames at the family level 1 - 0.05/12) on 64 x 64 Owen-Sobol frames: the error is a "
        "few pixels at the light's partly covered edge, and one or two frames where the U-Net "
        "misses one decide the mean; at the benchmark's 128 x 128 it is 0.73 of a-trous "
        "(denoisers/weights/README.md)"
    ),
}
#: Measured with this test's own run, at :data:`LEVEL` (every interval quoted is that one).
_NOT_BEYOND_INTERVAL = {
    **_NOT_BELOW_ONE,
    ("cornell", "white"): (
        "measured: U-Net / best tuned filter = 0.828 [0.598, 1.146] at the family level 1 - "
        "0.05/12 (at an uncorrected 95 % it was [0.689, 0.996]: below 1 only because one of 12 "
        "comparisons was picked without the correction)"
    ),
    ("direct", "white"): (
        "measured: U-Net / best tuned filter = 0.971 [0.848, 1.112] on independent-sample "
        "frames, which these weights were not trained on; a tie on a direct-lighting scene the "
        "joint bilateral filter's albedo and normal guides already denoise well"
    ),
    ("snooker", "owen_sobol"): (
        "measured: U-Net / best tuned filter = 0.954 [0.838, 1.086]: a near tie"
    ),
    ("snooker_plain", "white"): (
        "measured: U-Net / best tuned filter = 0.921 [0.775, 1.095] with the t-interval over the "
        "eight independent frames at the family level"
    ),
    ("snooker_plain", "owen_sobol"): (
        "measured: U-Net / best tuned filter = 0.981 [0.826, 1.166]: a tie on an untextured, "
        "mostly flat scene whose albedo and normal guides already separate its surfaces"
    ),
}


@functools.cache
def _held_out_comparison(scene, sampler):
    """U-Net MSE / best tuned filter's MSE on eight frames the filters were not tuned on.

    The filters are tuned on this very scene (one white-noise frame, same sampler); the U-Net
    never saw it. The best filter is picked by its mean MSE on the measured frames themselves,
    which favours the filters. The ratio's interval is :func:`bnerr.metrics.paired_ratio`'s
    t-interval over the eight frames, which are independent replicates here (each its own seed
    image of a static scene), at :data:`LEVEL` (corrected for the 12 comparisons).
    """
    tune_frame, _, reference = scene_renders(scene, sampler)
    frames = measured_frames(scene, sampler)
    filters = {
        name: get_denoiser(name, **tune(name, [tune_frame], [reference]).params)
        for name in GRIDS
        if not DENOISERS[name].stateful  # one frame each: the U-Net against the spatial filters
    }
    per_frame = {name: [mse(d(f), reference) for f in frames] for name, d in filters.items()}
    best = min(per_frame, key=lambda name: sum(per_frame[name]))
    unet = UNetDenoiser()
    return paired_ratio([mse(unet(f), reference) for f in frames], per_frame[best], level=LEVEL)


def _expect_failure(request, known, scene, sampler):
    reason = known.get((scene, sampler))
    if reason is not None:
        request.applymarker(pytest.mark.xfail(strict=True, reason=reason))


@pytest.mark.parametrize("sampler", SAMPLERS)
@pytest.mark.parametrize("scene", SCENES)
def test_unet_beats_the_best_tuned_filter_on_held_out_scenes(scene, sampler, request):
    _expect_failure(request, _NOT_BELOW_ONE, scene, sampler)
    assert _held_out_comparison(scene, sampler).value < 1.0


@pytest.mark.parametrize("sampler", SAMPLERS)
@pytest.mark.parametrize("scene", SCENES)
def test_unet_beats_the_best_tuned_filter_beyond_the_interval(scene, sampler, request):
    _expect_failure(request, _NOT_BEYOND_INTERVAL, scene, sampler)
    assert _held_out_comparison(scene, sampler).hi < 1.0


# -- weights are checked before the network is built (issue 18) ------------------------------------


def test_parameter_count_from_widths_equals_counting_the_built_network():
    from denoisers.unet import parameter_count_reference

    for widths in [DEFAULT_WIDTHS, (4, 6, 8, 8), (1, 1, 1, 1), (16, 8, 32, 4)]:
        assert parameter_count(widths) == parameter_count_reference(widths)


def test_a_tiny_file_asking_for_a_huge_network_is_refused_without_building_it(
    tmp_path, monkeypatch
):
    path = tmp_path / "huge.pt"
    payload = {"format": "bnerr-unet-weights-v1", "widths": [8192] * 4, "residual": True}
    torch.save({**payload, "state_dict": {}}, path)
    assert path.stat().st_size < 2000

    def never(*args, **kwargs):
        raise AssertionError("the network was built")

    monkeypatch.setattr(unet_module.UNet, "__init__", never)
    with pytest.raises(
        FileFormatError, match=r"huge.pt: widths: expected at most 500000 parameters, got widths"
    ):
        load_weights(path)
    torch.save({**payload, "widths": "abcd", "state_dict": {}}, path)
    with pytest.raises(FileFormatError, match="expected 4 positive integers"):
        load_weights(path)


def test_denoiser_fast_path_gives_the_plain_networks_output():
    """UNetDenoiser runs a FastUNet on the CPU (issue 16); the weights' network is untouched.

    Tolerance: 1e-4 relative, 1e-5 absolute: the fast path sums the convolutions in another order
    (measured at most 5e-6 on a 960 x 540 and a 1920 x 1080 synthetic frame)."""
    frame = random_frame(67, 45, scale=3.0)
    denoiser = UNetDenoiser()
    want = unet_denoise(denoiser.model, frame.color, frame.albedo, frame.normal)
    torch.testing.assert_close(denoiser(frame), want, rtol=1e-4, atol=1e-5)
    assert isinstance(denoiser._models[("fast", "cpu")], FastUNet)
    assert denoiser.model.enc1.weight.is_contiguous()  # the loaded network stays as it was


# FastUNet against the plain eager forward. Measured on the shipped weights, inputs up to 3 (the
# log color's range), 2 x 9 x {37 x 53, 67 x 45, 9 x 15, 1 x 1}: at most 1.6e-6 absolute on
# outputs up to 3.1, about 7 float32 ulps (the folded kernels and fused sums add in another
# order), the same with and without oneDNN's fused op. 1e-5 absolute and relative leaves room for
# other CPUs, whose oneDNN kernels block the sums differently.
FAST_TOL = {"rtol": 1e-5, "atol": 1e-5}


def _net_input(h, w, batch=2, seed=0):
    g = torch.Generator().manual_seed(seed)
    scale = torch.tensor([3.0] * 3 + [1.0] * 6).view(1, 9, 1, 1)
    return torch.rand(batch, 9, h, w, generator=g) * scale


@pytest.mark.parametrize("h, w", [(37, 53), (1, 1), (16, 24)])
def test_fast_unet_matches_the_plain_forward_on_the_shipped_weights(h, w):
    net = load_weights(DEFAULT_WEIGHTS)
    x = _net_input(h, w)
    with torch.no_grad():
        want, got = net(x), FastUNet(net)(x)
    assert got.shape == want.shape == (2, 3, h, w)
    torch.testing.assert_close(got, want, **FAST_TOL)


@pytest.mark.parametrize("residual", [True, False])
def test_fast_unet_matches_the_plain_forward_on_other_widths(residual):
    torch.manual_seed(1)
    net = UNet((5, 7, 6, 3), residual=residual).eval()
    x = _net_input(21, 19, batch=1)
    with torch.no_grad():
        torch.testing.assert_close(FastUNet(net)(x), net(x), **FAST_TOL)


def test_fast_unet_is_bit_identical_run_to_run_and_across_thread_counts():
    fast, x = FastUNet(load_weights(DEFAULT_WEIGHTS)), _net_input(37, 53)
    threads = torch.get_num_threads()
    try:
        with torch.no_grad():
            first = fast(x)
            assert torch.equal(fast(x), first)
            torch.set_num_threads(1 if threads > 1 else 2)
            assert torch.equal(fast(x), first)
    finally:
        torch.set_num_threads(threads)


def test_fast_unet_outputs_are_new_while_it_keeps_its_buffers_between_sizes():
    """The kept activation buffers never leak into a result: an earlier output stays as it was
    after later calls, at the same size and at others (which replace the buffers)."""
    net = load_weights(DEFAULT_WEIGHTS)
    fast = FastUNet(net)
    x, y = _net_input(16, 24, batch=1), _net_input(21, 13, batch=2, seed=1)
    with torch.no_grad():
        first = fast(x)
        kept = first.clone()
        torch.testing.assert_close(fast(y), net(y), **FAST_TOL)
        assert torch.equal(fast(x), kept) and torch.equal(first, kept)
    assert all(b.shape[0] == 1 for b in fast._buffers.values())  # the last size's only
    assert fast._packs and all(key[1] == 1 for key in fast._packs)  # weights packed for it


@pytest.mark.parametrize("fused", [True, False])
@pytest.mark.parametrize("residual", [True, False])
def test_fast_unet_in_strips_of_rows_equals_it_in_one_strip(monkeypatch, fused, residual):
    """The full-resolution tail in strips (with halos, border strips padded) against one strip
    (the whole image): equal on this machine, bit for bit, for every strip height tried (8 to
    10 ** 9, 1080p included); float tolerance for CPUs whose kernels block sums by shape."""
    torch.manual_seed(2)
    net = UNet((6, 5, 4, 3), residual=residual).eval()
    x = _net_input(45, 19)
    if not fused:
        monkeypatch.setattr(unet_module, "_fused_op", lambda: None)
    whole, strips = FastUNet(net), FastUNet(net)
    whole.strip_rows = 10**9
    with torch.no_grad():
        want = whole(x)
        for rows in (1, 8, 9, 16, 40):
            strips.strip_rows = rows
            torch.testing.assert_close(strips(x), want, rtol=1e-6, atol=1e-6)
        torch.testing.assert_close(want, net(x), **FAST_TOL)


def test_fast_unet_on_parts_is_the_fast_unet_on_their_concatenation():
    net = load_weights(DEFAULT_WEIGHTS)
    fast, x = FastUNet(net), _net_input(13, 22)
    parts = [x[:, :3], x[:, 3:6].clone(), x[:, 6:]]
    with torch.no_grad():
        assert torch.equal(fast.call_parts(parts), fast(x))
    assert torch.equal(fast.call_parts(parts), net(x))  # gradients enabled: the plain network


def test_fast_unet_refuses_parts_of_different_sizes():
    fast, x = FastUNet(load_weights(DEFAULT_WEIGHTS)), _net_input(8, 8)
    with torch.no_grad(), pytest.raises(ShapeError, match="parts of one B, H, W"):
        fast.call_parts([x[:, :3], x[:, 3:, :7]])
    with torch.no_grad(), pytest.raises(ShapeError):
        fast(x[0])


def test_fast_unet_calls_from_two_threads_take_turns_and_agree():
    from concurrent.futures import ThreadPoolExecutor

    fast, x = FastUNet(load_weights(DEFAULT_WEIGHTS)), _net_input(24, 40)
    with torch.no_grad():
        want = fast(x)

    def run(_):
        with torch.no_grad():
            return fast(x)

    with ThreadPoolExecutor(2) as pool:
        assert all(torch.equal(got, want) for got in pool.map(run, range(4)))


@pytest.mark.parametrize("fused", [True, False])
def test_conv_into_sums_into_its_output_in_place(monkeypatch, fused):
    g = torch.Generator().manual_seed(3)
    x = torch.randn(1, 5, 6, 7, generator=g).contiguous(memory_format=torch.channels_last)
    weight, bias = torch.randn(4, 5, 3, 3, generator=g), torch.randn(4, generator=g)
    out = torch.randn(1, 4, 6, 7, generator=g).contiguous(memory_format=torch.channels_last)
    want = torch.relu(torch.nn.functional.conv2d(x, weight, bias, padding=1) + out)
    if not fused:
        monkeypatch.setattr(unet_module, "_fused_op", lambda: None)
    with torch.no_grad():
        got = conv_into(out, x, weight, bias, relu=True)
    assert got is out
    torch.testing.assert_close(got, want, rtol=1e-5, atol=1e-5)


def test_fast_unet_without_onednns_fused_op_gives_the_same_output(monkeypatch):
    net = load_weights(DEFAULT_WEIGHTS)
    x = _net_input(13, 11)
    with torch.no_grad():
        fused = FastUNet(net)(x)
        monkeypatch.setattr(unet_module, "_fused_op", lambda: None)
        plain = FastUNet(net)(x)
        torch.testing.assert_close(plain, net(x), **FAST_TOL)
    torch.testing.assert_close(plain, fused, **FAST_TOL)


def test_fast_unet_defers_to_the_plain_network_for_gradients_and_other_dtypes():
    net = load_weights(DEFAULT_WEIGHTS)
    fast, x = FastUNet(net), _net_input(9, 10)
    assert torch.equal(fast(x), net(x))  # gradients enabled: training's forward, unchanged
    net.double()  # the plain network the fast path holds, now in float64
    with torch.no_grad():
        assert torch.equal(fast(x.double()), net(x.double()))


@pytest.mark.parametrize("h, w", [(5, 7), (1, 1), (6, 4), (3, 8)])
def test_transposed_kernel_on_the_low_resolution_input_is_the_conv_of_the_upsampled_input(h, w):
    """The stride-2 transposed convolution of the upsampled part of a decoder kernel, against
    the slow, obviously correct twin: upsample, then the 3 x 3 convolution (zero padding)."""
    g = torch.Generator().manual_seed(h * w + 1)
    low, weight = torch.randn(2, 4, h, w, generator=g), torch.randn(6, 4, 3, 3, generator=g)
    want = torch.nn.functional.conv2d(
        torch.nn.functional.interpolate(low, scale_factor=2.0, mode="nearest"), weight, padding=1
    )
    kernel = upsampled_transpose_kernel(weight)
    assert kernel.shape == (4, 6, 4, 4)
    low = low.contiguous(memory_format=torch.channels_last)
    got = torch.nn.functional.conv_transpose2d(low, kernel, stride=2, padding=1)
    # Sums of 36 products of unit normals: float32 rounding, measured below 4e-6.
    torch.testing.assert_close(got, want, rtol=1e-5, atol=2e-5)


def test_unet_blue_is_registered_with_its_own_shipped_weights():
    from denoisers import get_denoiser
    from denoisers.unet import BLUE_WEIGHTS, DEFAULT_WEIGHTS

    blue, white = get_denoiser("unet_blue"), get_denoiser("unet")
    assert blue.weights == BLUE_WEIGHTS and white.weights == DEFAULT_WEIGHTS
    assert BLUE_WEIGHTS.exists()
    # Same architecture, other weights.
    assert blue.model.widths == white.model.widths
    assert any(
        not torch.equal(a, b)
        for a, b in zip(blue.model.state_dict().values(), white.model.state_dict().values())
    )

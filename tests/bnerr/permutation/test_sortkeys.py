"""Tests for bnerr.permutation.sortkeys: the keys (luminance bit for bit the sorting pass's own,
residual, relative, demodulated), the label-guided smoothing against its slow twin, group labels
against theirs, and typed errors."""

import math

import pytest
import torch
from hypothesis import example, given
from hypothesis import strategies as st

from bnerr.color import luminance
from bnerr.errors import DtypeError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.frame import Frame
from bnerr.permutation.permute import plan_sort, sort_pass
from bnerr.permutation.sortkeys import (
    KINDS,
    demodulated,
    frame_sort_key,
    group_labels,
    group_labels_reference,
    smooth_luminance,
    smooth_luminance_reference,
    sort_key,
)


def _buffers(seed: int, h: int, w: int, special: float):
    gen = torch.Generator().manual_seed(seed)
    color = torch.rand(3, h, w, generator=gen)
    color[torch.rand(3, h, w, generator=gen) < special] = math.nan
    color[torch.rand(3, h, w, generator=gen) < special / 2] = math.inf
    albedo = torch.rand(3, h, w, generator=gen)
    albedo[torch.rand(3, h, w, generator=gen) < 0.2] = 0.0
    oid = torch.randint(-1, 3, (1, h, w), generator=gen).float()
    normal = torch.nn.functional.normalize(torch.randn(3, h, w, generator=gen), dim=0)
    normal[:, torch.rand(h, w, generator=gen) < 0.1] = 0.0
    depth = torch.rand(1, h, w, generator=gen) * 20
    depth[torch.rand(1, h, w, generator=gen) < 0.1] = 0.0
    return color, albedo, oid, normal, depth


@given(
    h=st.integers(1, 11),
    w=st.integers(1, 11),
    radius=st.integers(1, 3),
    guided=st.booleans(),
    special=st.sampled_from([0.0, 0.2]),
    seed=st.integers(0, 2**16),
)
@example(h=11, w=11, radius=2, guided=True, special=0.2, seed=1)
def test_smoothing_equals_its_slow_twin(h, w, radius, guided, special, seed):
    color, _, oid, normal, _ = _buffers(seed, h, w, special)
    lum = luminance(color)
    labels = group_labels(oid, normal) if guided else None
    got = smooth_luminance(lum, labels, radius)
    want = smooth_luminance_reference(lum, labels, radius)
    assert got.dtype == torch.float32 and got.shape == (h, w)
    assert torch.equal(got.nan_to_num(-7.0), want.nan_to_num(-7.0))


@given(
    h=st.integers(1, 9),
    w=st.integers(1, 9),
    normals=st.booleans(),
    depths=st.booleans(),
    bins=st.integers(1, 8),
    seed=st.integers(0, 2**16),
)
def test_group_labels_equal_their_slow_twin(h, w, normals, depths, bins, seed):
    _, _, oid, normal, depth = _buffers(seed, h, w, 0.0)
    oid[0, 0, 0] = math.nan
    depth[0, -1, -1] = math.inf
    args = (oid, normal if normals else None, depth if depths else None)
    got = group_labels(*args, depth_bins_per_octave=bins)
    assert got.dtype == torch.int64 and got.shape == (h, w)
    assert torch.equal(got, group_labels_reference(*args, depth_bins_per_octave=bins))


def test_group_labels_separate_objects_normals_and_depths():
    oid = torch.tensor([[[0.0, 0.0, 1.0, 0.0, 0.0]]])
    normal = torch.tensor([[0, 0, 0, 0, 0.0], [0, 0, 0, 0, 0], [1, 1, 1, -1, 1]]).view(3, 1, 5)
    depth = torch.tensor([[[1.0, 1.1, 1.0, 1.0, 4.0]]])
    labels = group_labels(oid, normal, depth)[0].tolist()
    assert labels[0] == labels[1]  # 1.0 and 1.1: same bin of a quarter octave
    assert len(set(labels)) == 4  # other object, flipped normal, two octaves farther
    assert group_labels(oid)[0].tolist() == [2, 2, 3, 2, 2]


def test_luminance_key_is_the_sort_pass_own_key():
    color, albedo, *_ = _buffers(3, 13, 17, 0.1)
    key = sort_key(color, "luminance")
    assert torch.equal(key.nan_to_num(-1.0), luminance(color).nan_to_num(-1.0))
    seeds = torch.randperm(13 * 17).view(13, 17)
    plan = plan_sort(torch.rand(13, 17), 4)
    assert torch.equal(sort_pass(seeds, key, plan), sort_pass(seeds, color, plan))


def test_residual_and_relative_follow_their_definitions():
    color, albedo, oid, normal, _ = _buffers(4, 12, 14, 0.05)
    labels = group_labels(oid, normal)
    for demodulate in (False, True):
        base = demodulated(color, albedo) if demodulate else color
        lum = luminance(base)
        smooth = smooth_luminance(lum, labels, 2)
        kwargs = dict(demodulate=demodulate, albedo=albedo, labels=labels, radius=2, eps=0.01)
        residual = sort_key(color, "residual", **kwargs)
        relative = sort_key(color, "relative", **kwargs)
        assert torch.equal(residual.nan_to_num(9.0), (lum - smooth).nan_to_num(9.0))
        want = (lum - smooth) / (smooth.abs() + 0.01)
        assert torch.equal(relative.nan_to_num(9.0), want.nan_to_num(9.0))


def test_demodulation_removes_a_texture_and_keeps_zero_albedo_pixels():
    albedo = torch.tensor([0.25, 0.5, 0.0]).view(3, 1, 1).expand(3, 2, 2).clone()
    albedo[:, 0, 0] = 1.0
    color = albedo * 2.0
    color[2] = 3.0
    out = demodulated(color, albedo)
    assert out[:2].eq(2.0).all() and out[2, 1, 1] == 3.0 and out[2, 0, 0] == 3.0
    # A constant radiance over a texture: the demodulated residual is zero everywhere.
    gen = torch.Generator().manual_seed(5)
    texture = torch.rand(1, 9, 9, generator=gen).expand(3, 9, 9) + 0.1
    key = sort_key(texture * 0.7, "residual", demodulate=True, albedo=texture)
    assert key.abs().max() < 1e-6
    assert sort_key(texture * 0.7, "residual").abs().max() > 0.05


def test_an_isolated_pixel_has_residual_zero_and_a_constant_image_too():
    labels = torch.arange(25).view(5, 5)  # nobody shares a label
    color = torch.rand(3, 5, 5, generator=torch.Generator().manual_seed(6))
    assert sort_key(color, "residual", labels=labels).eq(0).all()
    assert sort_key(torch.full((3, 6, 7), 0.5), "relative").eq(0).all()


def test_frame_sort_key_uses_the_frame_buffers():
    color, albedo, oid, normal, depth = _buffers(7, 10, 12, 0.0)
    frame = Frame(color=color, albedo=albedo, normal=normal, depth=depth, object_id=oid)
    for kind in KINDS:
        want = sort_key(
            color, kind, demodulate=True, albedo=albedo, labels=group_labels(oid, normal)
        )
        assert torch.equal(frame_sort_key(frame, kind, demodulate=True), want)
    assert torch.equal(frame_sort_key(Frame(color=color), "residual"), sort_key(color, "residual"))


def test_sort_keys_reject_bad_input_with_typed_errors():
    color = torch.rand(3, 4, 5)
    with pytest.raises(UnknownNameError, match=r"sort key"):
        sort_key(color, "variance")
    with pytest.raises(ValueRangeError, match=r"demodulate: expected an albedo buffer"):
        sort_key(color, demodulate=True)
    with pytest.raises(ShapeError, match=r"albedo: expected H x W = 4 x 5, got 4 x 4"):
        sort_key(color, demodulate=True, albedo=torch.rand(3, 4, 4))
    with pytest.raises(ShapeError, match=r"color: expected"):
        sort_key(torch.rand(4, 5))
    with pytest.raises(DtypeError, match=r"labels: expected dtype .*, got float32"):
        sort_key(color, "residual", labels=torch.zeros(4, 5))
    with pytest.raises(ValueRangeError, match=r"radius: expected an integer in \[1, 4\], got 5"):
        smooth_luminance(torch.rand(4, 5), radius=5)
    with pytest.raises(ShapeError, match=r"normal: expected"):
        group_labels(torch.zeros(1, 4, 5), torch.zeros(3, 4, 6))


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_cuda_matches_cpu():
    color, albedo, oid, normal, depth = _buffers(8, 37, 41, 0.05)
    labels = group_labels(oid, normal, depth)
    assert torch.equal(group_labels(oid.cuda(), normal.cuda(), depth.cuda()).cpu(), labels)
    for kind in KINDS:
        want = sort_key(color, kind, demodulate=True, albedo=albedo, labels=labels, radius=2)
        got = sort_key(
            color.cuda(),
            kind,
            demodulate=True,
            albedo=albedo.cuda(),
            labels=labels.cuda(),
            radius=2,
        )
        assert torch.equal(got.cpu().nan_to_num(5.0), want.nan_to_num(5.0)), kind

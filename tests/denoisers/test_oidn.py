"""Tests of denoisers/oidn.py: the Intel Open Image Denoise reference behind the interface."""

import importlib

import pytest
import torch

import denoisers.oidn as oidn_module
from bnerr.errors import MissingExtraError
from bnerr.frame import Frame
from denoisers import get_denoiser
from denoisers.oidn import available_denoisers, oidn_denoise
from tests._scene_renders import SCENES, mse, scene_renders

pyoidn = pytest.importorskip("pyoidn", reason="needs the optional extra 'reference'")
pytestmark = pytest.mark.reference


def _noisy_frame(seed=0, h=48, w=40):
    g = torch.Generator().manual_seed(seed)
    albedo = torch.where(torch.arange(w) < w // 2, 0.7, 0.3).expand(3, h, w).clone()
    normal = torch.tensor([0.0, 0.0, 1.0])[:, None, None].expand(3, h, w).clone()
    clean = albedo * 1.5
    # Exponential noise: positive and skewed like Monte Carlo radiance at low spp, unbiased.
    noisy = clean * -torch.rand(3, h, w, generator=g).clamp_min(1e-7).log()
    return Frame(color=noisy, albedo=albedo, normal=normal), clean


def test_lowers_error_and_keeps_layout():
    frame, clean = _noisy_frame()
    out = get_denoiser("oidn")(frame)
    assert out.shape == (3, 48, 40) and out.dtype == torch.float32
    assert float((out - clean).square().mean()) < 0.2 * float((frame.color - clean).square().mean())


def test_matches_pyoidn_called_directly_on_hwc():
    frame, _ = _noisy_frame(seed=1, h=20, w=24)
    ours = oidn_denoise(frame.color, frame.albedo, frame.normal)
    hwc = [x.permute(1, 2, 0).contiguous() for x in (frame.color, frame.albedo, frame.normal)]
    direct = pyoidn.denoise(*hwc, hdr=True, quality="high")
    assert torch.equal(ours, direct.permute(2, 0, 1))


def test_missing_extra_names_it(monkeypatch):
    real = importlib.import_module

    def fake_import(name, *args):
        if name == "pyoidn":
            raise ModuleNotFoundError("No module named 'pyoidn'")
        return real(name, *args)

    monkeypatch.setattr(oidn_module.importlib, "import_module", fake_import)
    with pytest.raises(
        MissingExtraError, match=r"oidn: expected the optional extra 'reference'.*pyoidn"
    ):
        get_denoiser("oidn")
    assert issubclass(MissingExtraError, ImportError)
    # a study or test that lists oidn among its denoisers drops it where the extra is missing
    assert available_denoisers(["atrous", "oidn", "unet"]) == ["atrous", "unet"]


def test_available_denoisers_keeps_oidn_where_the_extra_is_installed():
    assert available_denoisers(["oidn", "atrous"]) == ["oidn", "atrous"]


@pytest.mark.parametrize("scene", SCENES)
def test_oidn_lowers_mse_on_every_scene_at_4spp(scene):
    _, frame, reference = scene_renders(scene)
    assert mse(get_denoiser("oidn")(frame), reference) < mse(frame.color, reference)

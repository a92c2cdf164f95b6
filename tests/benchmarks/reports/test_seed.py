"""The seed suite's figures and README (benchmarks.reports.seed), from small records."""

from __future__ import annotations

import dataclasses

import numpy as np
from PIL import Image

from benchmarks.reports.gap import gap_shares
from benchmarks.reports.seed import write_seed_report
from benchmarks.sweep.records import Spectrum
from tests._records import metric_pairs, small_record

_VALUES = {"white": 1.0, "temporal": 0.8, "oracle": 0.3}


def _records(tmp_path, spp=16, coherent_spectrum=True):
    (tmp_path / "crops").mkdir(exist_ok=True)
    gen = np.random.default_rng(5)
    out = []
    for strategy, v in _VALUES.items():
        pairs = metric_pairs([[v] * 2] * 2)
        metrics = {m: pairs for m in ("mse", "mse_blur1", "mse_blur2")}
        rec = small_record(
            strategy, "gaussian", raw=metrics, den=metrics, frames=2, seed_sets=2, spp=spp
        )
        crop = f"crops/{strategy}_{spp}.npz"
        tiles = {k: gen.integers(0, 256, (16, 16, 3), dtype=np.uint8) for k in ("reference", "raw")}
        np.savez_compressed(tmp_path / crop, **tiles)
        spectra = dict(rec.spectrum)
        if coherent_spectrum:
            spectra["coherent"] = Spectrum(freq=[0.0, 0.1, 0.2], power=[1.0, v, v])
        for region in ("all", "coherent"):
            cell = dataclasses.replace(rec.cell, region=region)
            out.append(dataclasses.replace(rec, cell=cell, crop=crop, spectrum=spectra))
    return out


def test_figures_and_readme_come_from_the_records(tmp_path):
    records = _records(tmp_path) + _records(tmp_path, spp=64)
    written = write_seed_report(tmp_path, records, gap_shares(records))
    names = sorted(p.name for p in written)
    assert names == ["README.md", "seed_direct_16spp.png", "seed_direct_64spp.png"]
    with Image.open(tmp_path / "seed_direct_16spp.png") as image:
        assert image.width > 3 * image.height  # four images and a spectrum in one row
    text = (tmp_path / "README.md").read_text()
    share = (1.0 - 0.8) / (1.0 - 0.3)  # the temporal strategy's share of the dividend
    assert f"| 16 | {0.7:.2f} | {share:.2f} [{share:.2f}, {share:.2f}] |" in text
    assert f"best temporal keeps {share:.2f}" in text and "**fails**" in text  # 0.29 < 1/2
    assert "![direct, 16spp](seed_direct_16spp.png)" in text


def test_other_suites_get_no_seed_report(tmp_path):
    records = _records(tmp_path, coherent_spectrum=False)
    assert write_seed_report(tmp_path, records, gap_shares(records)) == []
    assert not (tmp_path / "README.md").exists()

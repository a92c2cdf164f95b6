"""The preview images of the results page: one PNG strip per run's crops, with error maps.

A run with crops (:mod:`benchmarks.sweep.measure`) saves ``crops/<run>.npz``: the sRGB previews
of the reference, the raw frame and every denoised frame of its first measured frame, at the
rendered size of the crop. :func:`write_previews` turns each into ``previews/<run>.png``, the
tiles side by side in :func:`tile_names` order: the reference, the raw frame and its error map,
then for each key denoiser (:func:`benchmarks.reports.charts.key_denoisers`) the denoised frame and
its error map. An error map is ``|image - reference|`` in sRGB, times :data:`ERROR_GAIN`, so the
page shows it without reading pixels (which a browser forbids for pages opened from disk).

Not for: the crops chart (:func:`load_crop` reads the same arrays for it).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from bnerr.errors import FileFormatError
from bnerr.io import atomic_write

__all__ = ["ERROR_GAIN", "PREVIEWS", "load_crop", "tile_names", "write_previews"]

#: Amplification of the error maps (an error of 1/4 of the range reaches white).
ERROR_GAIN = 4
#: Folder of the preview strips in a results folder.
PREVIEWS = "previews"


def load_crop(out_dir: str | Path, crop: str | None) -> dict[str, np.ndarray] | None:
    """The crops of a record (``reference``, ``raw``, ``denoised/<name>``: uint8 ``H x W x 3``),
    or None when it has none or its file is missing.

    Raises:
        FileFormatError: the file is not a readable ``.npz``.
    """
    if not crop or not (Path(out_dir) / crop).exists():
        return None
    path = Path(out_dir) / crop
    try:
        with np.load(path) as data:
            return {k.replace("__", "/"): data[k] for k in data.files}
    except (OSError, ValueError) as err:
        raise FileFormatError(f"{path}: expected the crops of a run (.npz), got {err}") from None


def tile_names(crop: dict[str, np.ndarray], denoisers: Sequence[str]) -> list[str]:
    """The tiles of a preview strip, in order: ``reference``, ``raw``, ``raw/error``, then
    ``denoised/<d>`` and ``denoised/<d>/error`` for each of ``denoisers`` the crop holds."""
    names = ["reference", "raw", "raw/error"]
    for d in denoisers:
        if f"denoised/{d}" in crop:
            names += [f"denoised/{d}", f"denoised/{d}/error"]
    return names


def _tile(crop: dict[str, np.ndarray], name: str) -> np.ndarray:
    if not name.endswith("/error"):
        return crop[name]
    diff = np.abs(crop[name.removesuffix("/error")].astype(np.int16) - crop["reference"])
    return np.clip(diff * ERROR_GAIN, 0, 255).astype(np.uint8)


def write_previews(
    out_dir: str | Path, crop: str, denoisers: Sequence[str]
) -> tuple[str, list[str]] | None:
    """Write the preview strip of one record's ``crop`` (a path relative to ``out_dir``); return
    its path relative to ``out_dir`` and its tile names, or None when the crop is missing."""
    from PIL import Image

    images = load_crop(out_dir, crop)
    if images is None:
        return None
    names = tile_names(images, denoisers)
    strip = np.concatenate([_tile(images, n) for n in names], axis=1)
    rel = f"{PREVIEWS}/{Path(crop).stem}.png"
    path = Path(out_dir) / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as tmp:
        Image.fromarray(strip).save(tmp, format="PNG", optimize=True)
    return rel, names

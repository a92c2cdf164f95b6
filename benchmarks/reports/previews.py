"""The crops of a results folder as PNG strips, what the results page and the charts show.

A run with crops (:mod:`benchmarks.sweep.measure`) saves ``crops/<run>.npz``: the sRGB previews
(uint8, at the crop's rendered size) of the reference, the raw frame and every denoised frame of
its first measured frame. The report keeps them as ``crops/<run>.png`` instead
(:func:`crop_strip`): the same tiles side by side, lossless, their names in the PNG's ``tiles``
text chunk, which a browser can show directly; the ``.npz`` is removed once the strip reads back
equal (the record still names the ``.npz``: :func:`load_crop` reads the strip in its place).

The page draws the error maps itself, ``|image - reference|`` in sRGB times :data:`ERROR_GAIN`,
by blending two tiles of the strip in CSS (``difference``, then a brightness filter): no script
reads a pixel (a browser forbids it for pages opened from disk) and no error image is stored.

Not for: choosing what to show (:mod:`benchmarks.reports.page`, :mod:`benchmarks.reports.charts`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from bnerr.errors import FileFormatError
from bnerr.io import atomic_write

__all__ = ["ERROR_GAIN", "crop_strip", "load_crop"]

#: Amplification of the error maps (an error of 1/4 of the range reaches white).
ERROR_GAIN = 4
_TILES = "tiles"


def _read_npz(path: Path) -> dict[str, np.ndarray]:
    try:
        with np.load(path) as data:
            return {k.replace("__", "/"): data[k] for k in data.files}
    except (OSError, ValueError) as err:
        raise FileFormatError(f"{path}: expected the crops of a run (.npz), got {err}") from None


def _read_png(path: Path) -> dict[str, np.ndarray]:
    from PIL import Image, PngImagePlugin

    try:
        with Image.open(path) as image:
            if not isinstance(image, PngImagePlugin.PngImageFile):
                raise ValueError(f"a {image.format} image")
            names = json.loads(image.text[_TILES])
            strip = np.asarray(image.convert("RGB"))
    except (OSError, ValueError, KeyError) as err:
        raise FileFormatError(f"{path}: expected a strip of crops (.png), got {err!r}") from None
    width = strip.shape[1] // max(len(names), 1)
    return {n: strip[:, i * width : (i + 1) * width] for i, n in enumerate(names)}


def _strip_path(out_dir: str | Path, crop: str) -> Path:
    return (Path(out_dir) / crop).with_suffix(".png")


def load_crop(out_dir: str | Path, crop: str | None) -> dict[str, np.ndarray] | None:
    """The crops of a record (``reference``, ``raw``, ``denoised/<name>``: uint8 ``H x W x 3``),
    from its ``.npz`` or the strip that replaced it; None when it has none or both are missing.

    Raises:
        FileFormatError: the file is not a readable ``.npz`` or strip.
    """
    if not crop:
        return None
    path = Path(out_dir) / crop
    if path.suffix == ".npz" and path.exists():
        return _read_npz(path)
    strip = _strip_path(out_dir, crop)
    return _read_png(strip) if strip.exists() else None


def crop_strip(out_dir: str | Path, crop: str | None) -> tuple[str, list[str]] | None:
    """The strip of a record's crops (path relative to ``out_dir``, tile names in order),
    written from its ``.npz`` first if need be (which is then removed); None without crops."""
    from PIL import Image
    from PIL.PngImagePlugin import PngInfo

    if not crop:
        return None
    strip = _strip_path(out_dir, crop)
    rel = str(Path(crop).with_suffix(".png"))
    if strip.exists() and not (Path(out_dir) / crop).with_suffix(".npz").exists():
        return rel, list(_read_png(strip))
    images = load_crop(out_dir, crop)
    if images is None:
        return None
    names = list(images)
    info = PngInfo()
    info.add_text(_TILES, json.dumps(names))
    with atomic_write(strip) as tmp:
        Image.fromarray(np.concatenate(list(images.values()), axis=1)).save(
            tmp, format="PNG", pnginfo=info, optimize=True
        )
    back = _read_png(strip)
    if any(not np.array_equal(back[n], images[n]) for n in names):
        raise FileFormatError(f"{strip}: expected the crops to read back equal, got a difference")
    (Path(out_dir) / crop).with_suffix(".npz").unlink(missing_ok=True)
    return rel, names

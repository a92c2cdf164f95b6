"""The crops of a results folder as lossless WebP strips, what the results page and the charts
show.

A run with crops (:mod:`benchmarks.sweep.measure`) saves ``crops/<run>.npz``: the sRGB previews
(uint8, at the crop's rendered size) of the reference, the raw frame and every denoised frame of
its first measured frame. The report keeps them as ``crops/<run>.webp`` instead
(:func:`crop_strip`): the same tiles side by side, lossless (two thirds of the bytes of a PNG of
the same noise), their names as JSON in the image's EXIF description, which a browser can show
directly; the ``.npz`` (or the ``.png`` strip older reports wrote) is removed once the strip reads
back equal (the record still names the ``.npz``: :func:`load_crop` reads the strip in its place).

The page draws the error maps itself, ``|image - reference|`` in sRGB times :data:`ERROR_GAIN`,
by blending two tiles of the strip in CSS (``difference``, then a brightness filter): no script
reads a pixel (a browser forbids it for pages opened from disk) and no error image is stored.

Not for: choosing what to show (:mod:`benchmarks.reports.page`, :mod:`benchmarks.reports.charts`).
"""

from __future__ import annotations

import json
from collections.abc import Collection
from pathlib import Path

import numpy as np

from bnerr.errors import FileFormatError
from bnerr.io import atomic_write

__all__ = ["ERROR_GAIN", "crop_strip", "load_crop"]

#: Amplification of the error maps (an error of 1/4 of the range reaches white).
ERROR_GAIN = 4
_TILES = "tiles"
#: EXIF tag of the tile names (ImageDescription).
_DESCRIPTION = 0x010E


def _read_npz(path: Path) -> dict[str, np.ndarray]:
    try:
        with np.load(path) as data:
            return {k.replace("__", "/"): data[k] for k in data.files}
    except (OSError, ValueError) as err:
        raise FileFormatError(f"{path}: expected the crops of a run (.npz), got {err}") from None


def _read_strip(path: Path) -> dict[str, np.ndarray]:
    """The tiles of a strip: WebP with the names in its EXIF description, or an older PNG with
    them in its ``tiles`` text chunk."""
    from PIL import Image

    try:
        with Image.open(path) as image:
            if image.format == "WEBP":
                names = json.loads(image.getexif()[_DESCRIPTION])
            elif image.format == "PNG":
                names = json.loads(image.info[_TILES])
            else:
                raise ValueError(f"a {image.format} image")
            strip = np.asarray(image.convert("RGB"))
    except (OSError, ValueError, KeyError) as err:
        raise FileFormatError(f"{path}: expected a strip of crops, got {err!r}") from None
    width = strip.shape[1] // max(len(names), 1)
    return {n: strip[:, i * width : (i + 1) * width] for i, n in enumerate(names)}


def _strip_path(out_dir: str | Path, crop: str, suffix: str = ".webp") -> Path:
    return (Path(out_dir) / crop).with_suffix(suffix)


def load_crop(out_dir: str | Path, crop: str | None) -> dict[str, np.ndarray] | None:
    """The crops of a record (``reference``, ``raw``, ``denoised/<name>``: uint8 ``H x W x 3``),
    from its ``.npz`` or the strip that replaced it; None when it has none or all are missing.

    Raises:
        FileFormatError: the file is not a readable ``.npz`` or strip.
    """
    if not crop:
        return None
    path = Path(out_dir) / crop
    if path.suffix == ".npz" and path.exists():
        return _read_npz(path)
    for suffix in (".webp", ".png"):
        if (strip := _strip_path(out_dir, crop, suffix)).exists():
            return _read_strip(strip)
    return None


def crop_strip(
    out_dir: str | Path, crop: str | None, keep: Collection[str] | None = None
) -> tuple[str, list[str]] | None:
    """The strip of a record's crops (path relative to ``out_dir``, tile names in order),
    written from its ``.npz`` (or older ``.png`` strip) first if need be, which is then removed;
    None without crops.

    ``keep``: the tiles the page shows (names as :func:`load_crop`'s); the strip is written with
    those only, in their order in the crops, and a strip that holds others is written again
    without them (a run saves every denoiser's tile, a page shows the key ones: the quality
    suite's strips lost 9 of their 16 tiles, 2.0 of their 4.5 MB, that no page read). None
    keeps every tile.
    """
    from PIL import Image

    if not crop:
        return None
    strip = _strip_path(out_dir, crop)
    rel = str(Path(crop).with_suffix(".webp"))
    older = [_strip_path(out_dir, crop, s) for s in (".npz", ".png")]
    npz, png = older
    if strip.exists() and not any(p.exists() for p in older):
        images = _read_strip(strip)
        if keep is None or set(images) <= set(keep):
            return rel, list(images)
    elif npz.exists() or png.exists():
        images = _read_npz(npz) if npz.exists() else _read_strip(png)
    else:
        return None
    if keep is not None:
        images = {n: tile for n, tile in images.items() if n in keep}
    if not images:
        return None
    names = list(images)
    exif = Image.Exif()
    exif[_DESCRIPTION] = json.dumps(names)
    with atomic_write(strip) as tmp:
        Image.fromarray(np.concatenate(list(images.values()), axis=1)).save(
            tmp, format="WEBP", lossless=True, quality=100, method=6, exif=exif.tobytes()
        )
    back = _read_strip(strip)
    if any(not np.array_equal(back[n], images[n]) for n in names):
        raise FileFormatError(f"{strip}: expected the crops to read back equal, got a difference")
    for path in older:
        path.unlink(missing_ok=True)
    return rel, names

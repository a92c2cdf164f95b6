"""A folder of frames rendered anywhere, as ``bnerr eval`` reads it (docs/EVAL.md).

The layout (every file a linear HDR OpenEXR, channels as :mod:`bnerr.io` names them)::

    DIR/manifest.toml                        what the layout cannot say (MANIFEST_KEYS)
    DIR/reference/<tttt>.exr                 the reference of frame t (static: 0000.exr only)
    DIR/<method>/<seed_set>/<tttt>.exr       method's noisy frame t of that seed set
    DIR/<...>/<tttt>.<buffer>.exr            optional: an auxiliary buffer in a file of its own

``<tttt>`` is the frame index, four digits or more (``0006``). Frames ``0 .. warmup - 1`` are
the warmup frames (read only when a stateful denoiser must see them), ``warmup .. warmup +
frames - 1`` the measured ones. An auxiliary buffer (``albedo``, ``normal``, ``depth``,
``motion``, ``object_id``, ``variance``) named in the manifest's ``buffers`` is read from the
frame's own layer (``albedo.R albedo.G albedo.B``...) or, failing that, from the sibling file
``<tttt>.<buffer>.exr``, whose layer or plain channels (``R G B``; one channel; ``R G`` or ``X Y``
for motion) hold it. Buffers the manifest does not name are not read, but for a reference's
``variance`` layer (the variance of its pixel means), the records' noise floor where present.

Everything is checked before a pixel is read (:func:`check_folder`): the manifest's keys and
values, that every file it implies exists, sits inside ``DIR`` (no ``..``, no absolute name, no
symbolic link) and declares the manifest's resolution in its header (a file claiming another
size, however large, is refused before it is read). Reading a frame (:meth:`FrameFolder.frame`)
then refuses non-finite pixels. Each refusal is one typed error naming the file.

Not for: measuring (:mod:`benchmarks.evaluate`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from bnerr.errors import (
    FileFormatError,
    NonFiniteError,
    ShapeError,
    UnknownNameError,
    ValueRangeError,
    check_finite,
    toml_reason,
)
from bnerr.frame import BUFFERS, Frame
from bnerr.io import exr_size, read_exr, read_frame
from bnerr.metrics.regions import REGION_BUFFERS

__all__ = [
    "AUX_BUFFERS",
    "MANIFEST",
    "MANIFEST_KEYS",
    "MAX_PIXELS",
    "REFERENCE",
    "FrameFolder",
    "Manifest",
    "check_folder",
    "frame_name",
    "load_manifest",
    "parse_manifest",
    "reference_frames",
]

#: The manifest's file name inside the folder.
MANIFEST = "manifest.toml"
#: The folder of the reference frames.
REFERENCE = "reference"
#: The auxiliary buffers a frame may carry, and their channel counts.
AUX_BUFFERS: dict[str, int] = {**{k: v for k, v in BUFFERS.items() if k != "color"}, "variance": 3}
#: The largest frame the manifest may declare (``width * height``): 64 megapixels.
MAX_PIXELS = 1 << 26
#: The manifest's keys: name -> (required, what it holds).
MANIFEST_KEYS: dict[str, tuple[bool, str]] = {
    "scene": (True, "the scene's name (tables and pages)"),
    "spp": (True, "samples per pixel of the noisy frames"),
    "resolution": (True, "[width, height] of every frame"),
    "methods": (True, "the method folders, white (the baseline) among them"),
    "seed_sets": (True, "the seed-set folder names, the same under every method"),
    "frames": (True, "measured frames per seed set"),
    "warmup": (False, "frames before the measured ones (default 0)"),
    "buffers": (False, "auxiliary buffers of every frame (default none)"),
    "regions": (False, "pixel regions (default all, plus coherent where the buffers allow)"),
    "static": (False, "true: one reference, reference/0000.exr, serves every frame"),
    "reference_spp": (False, "samples per pixel of the references (default 0: unknown)"),
    "sampler": (False, "the per-pixel sampler, a label (default owen_sobol)"),
    "dimensions": (False, "sampler dimensions one path uses (default 0: unknown)"),
    "tuning_seed_set": (False, "a held-out seed-set folder the denoisers are tuned on"),
}
_RESERVED = (REFERENCE, "results")  # the reference folder, and the default --out
_COHERENT_NEEDS = REGION_BUFFERS["coherent"]
_REGION_NEEDS = {k: v for k, v in REGION_BUFFERS.items() if k in ("all", "edges", "coherent")}
_PLAIN = {3: (("R", "G", "B"),), 2: (("R", "G"), ("X", "Y"), ("U", "V"))}


def frame_name(t: int) -> str:
    """The file name of frame ``t``: ``0006.exr``."""
    return f"{t:04d}.exr"


@dataclass(frozen=True)
class Manifest:
    """The checked manifest (see :data:`MANIFEST_KEYS`)."""

    scene: str
    spp: int
    width: int
    height: int
    methods: tuple[str, ...]
    seed_sets: tuple[str, ...]
    frames: int
    warmup: int = 0
    buffers: tuple[str, ...] = ()
    regions: tuple[str, ...] = ()
    static: bool = False
    reference_spp: int = 0
    sampler: str = "owen_sobol"
    dimensions: int = 0
    tuning_seed_set: str | None = None


def _int(data: dict, key: str, default: int, minimum: int) -> int:
    value = data.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ValueRangeError(f"{MANIFEST}: {key}: expected an integer >= {minimum}, got {value!r}")
    return value


def _name(value: object, key: str) -> str:
    """A folder name: one plain path component (no separator, not ``.``/``..``, not hidden)."""
    if (
        not isinstance(value, str)
        or not value
        or value.startswith(".")
        or "/" in value
        or "\\" in value
        or value != value.strip()
        or not value.isprintable()
    ):
        raise ValueRangeError(
            f"{MANIFEST}: {key}: expected plain folder names inside the folder (no '/', '..', "
            f"absolute, hidden names or control characters), got {value!r}"
        )
    return value


def _names(data: dict, key: str, default: tuple[str, ...] | None = None) -> tuple[str, ...]:
    value = data.get(key, default)
    if not isinstance(value, (list, tuple)) or (default is None and not value):
        raise ValueRangeError(
            f"{MANIFEST}: {key}: expected a non-empty list of names, got {value!r}"
        )
    names = tuple(_name(v, key) for v in value)
    if len(set(names)) != len(names):
        raise ValueRangeError(f"{MANIFEST}: {key}: expected distinct names, got {list(names)}")
    return names


def _resolution(data: dict) -> tuple[int, int]:
    value = data.get("resolution")
    if not (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) and v >= 1 for v in value)
    ):
        raise ValueRangeError(f"{MANIFEST}: resolution: expected [width, height], got {value!r}")
    width, height = value
    if width * height > MAX_PIXELS:
        raise ValueRangeError(
            f"{MANIFEST}: resolution: expected at most {MAX_PIXELS} pixels, got {width} x {height}"
        )
    return width, height


def _regions(data: dict, buffers: tuple[str, ...], before: bool) -> tuple[str, ...]:
    """The manifest's regions (each checked against the buffers), or all plus coherent where the
    buffers allow (``before``: a reference precedes the first measured frame, or none is
    needed)."""
    if "regions" not in data:
        allowed = before and all(b in buffers for b in _COHERENT_NEEDS)
        return ("all", "coherent") if allowed else ("all",)
    regions = _names(data, "regions")
    if "coherent" in regions and not before:
        raise ValueRangeError(
            f"{MANIFEST}: region 'coherent': expected warmup >= 1 or static = true (its "
            "disocclusion test reads the reference of the frame before the first measured one), "
            "got warmup 0"
        )
    for region in regions:
        if region not in _REGION_NEEDS:
            raise UnknownNameError(
                f"{MANIFEST}: regions: expected names from {', '.join(_REGION_NEEDS)}, got "
                f"{region!r}"
            )
        missing = [b for b in _REGION_NEEDS[region] if b not in buffers]
        if missing:
            raise ValueRangeError(
                f"{MANIFEST}: region {region!r}: expected buffers {', '.join(missing)} in "
                f"buffers, got {list(buffers)}"
            )
    return regions


def _check_keys(data: dict) -> None:
    unknown = sorted(set(data) - set(MANIFEST_KEYS))
    if unknown:
        raise UnknownNameError(
            f"{MANIFEST}: unknown keys {', '.join(unknown)}; expected keys from "
            f"{', '.join(MANIFEST_KEYS)}"
        )
    missing = [k for k, (required, _) in MANIFEST_KEYS.items() if required and k not in data]
    if missing:
        raise ValueRangeError(f"{MANIFEST}: expected the keys {', '.join(missing)}, got none")


def _buffers(data: dict) -> tuple[str, ...]:
    buffers = _names(data, "buffers", ())
    for name in buffers:
        if name not in AUX_BUFFERS:
            raise UnknownNameError(
                f"{MANIFEST}: buffers: expected names from {', '.join(AUX_BUFFERS)}, got {name!r}"
            )
    return buffers


def _methods(data: dict) -> tuple[str, ...]:
    methods = _names(data, "methods")
    if "white" not in methods:
        raise ValueRangeError(
            f"{MANIFEST}: methods: expected the white baseline (a method named 'white'; every "
            f"ratio is to it), got {list(methods)}"
        )
    reserved = [m for m in methods if m in _RESERVED]
    if reserved:
        raise ValueRangeError(
            f"{MANIFEST}: methods: expected names other than {', '.join(_RESERVED)} (reserved), "
            f"got {', '.join(reserved)}"
        )
    return methods


def _text(data: dict, key: str, default: str) -> str:
    value = data.get(key, default)
    if not isinstance(value, str) or not value:
        raise ValueRangeError(f"{MANIFEST}: {key}: expected a non-empty string, got {value!r}")
    return value


def parse_manifest(data: dict[str, Any]) -> Manifest:
    """The :class:`Manifest` of a parsed TOML table.

    Raises:
        UnknownNameError: an unknown key (the message lists the known ones), buffer or region.
        ValueRangeError: a missing or bad value, or no method named ``white``.
    """
    _check_keys(data)
    width, height = _resolution(data)
    buffers = _buffers(data)
    seed_sets = _names(data, "seed_sets")
    tuning = data.get("tuning_seed_set")
    if tuning is not None and _name(tuning, "tuning_seed_set") in seed_sets:
        raise ValueRangeError(
            f"{MANIFEST}: tuning_seed_set: expected a folder apart from the measured seed sets "
            f"{list(seed_sets)}, got {tuning!r}"
        )
    static = data.get("static", False)
    if not isinstance(static, bool):
        raise ValueRangeError(f"{MANIFEST}: static: expected true or false, got {static!r}")
    warmup = _int(data, "warmup", 0, 0)
    return Manifest(
        scene=_text(data, "scene", ""),
        spp=_int(data, "spp", 0, 1),
        width=width,
        height=height,
        methods=_methods(data),
        seed_sets=seed_sets,
        frames=_int(data, "frames", 0, 1),
        warmup=warmup,
        buffers=buffers,
        regions=_regions(data, buffers, static or warmup >= 1),
        static=static,
        reference_spp=_int(data, "reference_spp", 0, 0),
        sampler=_text(data, "sampler", "owen_sobol"),
        dimensions=_int(data, "dimensions", 0, 0),
        tuning_seed_set=tuning,
    )


def load_manifest(folder: str | Path) -> Manifest:
    """The folder's ``manifest.toml``, checked (:func:`parse_manifest`).

    Raises:
        FileFormatError: no manifest, or not TOML.
    """
    path = Path(folder) / MANIFEST
    if not path.is_file():
        raise FileFormatError(f"{path}: expected the frame folder's manifest, got no such file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise FileFormatError(f"{path}: expected a TOML manifest in UTF-8, got {err}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        reason = toml_reason(err, text)
        raise FileFormatError(f"{path}: expected a TOML manifest, got {reason}") from None
    except (ValueError, RecursionError) as err:  # 5000-digit integers, deep nesting
        raise FileFormatError(f"{path}: expected a TOML manifest, got {err}") from None
    return parse_manifest(data)


class FrameFolder:
    """A checked frame folder: its manifest, and the frames read on demand.

    Args:
        root: the folder (``DIR``).
        manifest: its manifest (default: read from ``root``).
    """

    def __init__(self, root: str | Path, manifest: Manifest | None = None) -> None:
        self.root = Path(root)
        if not self.root.is_dir():
            raise FileFormatError(f"{self.root}: expected a frame folder, got no such folder")
        self.manifest = load_manifest(self.root) if manifest is None else manifest

    def path(self, *parts: str) -> Path:
        """``root / parts``, refused if it leaves the folder (``..``, absolute names, symbolic
        links anywhere below the folder)."""
        for part in parts:
            bad = part in ("", ".", "..") or any(c in part for c in "/\\\0")
            if bad or Path(part).is_absolute():
                raise ValueRangeError(
                    f"{self.root}: expected a path inside the folder, got {'/'.join(parts)!r}"
                )
        path = self.root.joinpath(*parts)
        inside = self.root.resolve().joinpath(*parts)
        if path.resolve() != inside:
            raise ValueRangeError(
                f"{path}: expected a file inside {self.root}, got a symbolic link to "
                f"{path.resolve()}"
            )
        return path

    def frame_path(self, method: str, seed_set: str, t: int) -> Path:
        return self.path(method, seed_set, frame_name(t))

    def reference_path(self, t: int) -> Path:
        return self.path(REFERENCE, frame_name(0 if self.manifest.static else t))

    def _sibling(self, path: Path, buffer: str) -> Path:
        return self.path(*path.relative_to(self.root).parts[:-1], f"{path.stem}.{buffer}.exr")

    def check_file(self, path: Path) -> None:
        """Refuse a missing file, or one whose header declares another size than the manifest's
        (before any pixel is read)."""
        if not path.is_file():
            raise FileFormatError(
                f"{path}: expected a frame the manifest implies, got no such file"
            )
        m = self.manifest
        size = exr_size(path)
        if size != (m.width, m.height):
            raise ShapeError(
                f"{path}: expected {m.width} x {m.height} (the manifest's resolution), got "
                f"{size[0]} x {size[1]} in its header; refused before reading"
            )

    def read_file(self, path: Path, reference: bool = False) -> Frame:
        """The frame at ``path`` (a reference's with its variance), checked: its size, the
        manifest's buffers, every value finite."""
        self.check_file(path)
        frame = read_frame(path)
        found: dict[str, torch.Tensor] = {}
        if reference and frame.variance is not None:  # the reference's noise floor
            found["variance"] = frame.variance
        for buffer in self.manifest.buffers:
            value = getattr(frame, buffer)
            found[buffer] = value if value is not None else self._sibling_buffer(path, buffer)
        kept: dict[str, Any] = {b: found.get(b) for b in AUX_BUFFERS}
        frame = dataclasses.replace(frame, **kept)
        for name, value in frame.buffers().items():
            try:
                check_finite(value, name)
            except NonFiniteError as err:
                raise NonFiniteError(f"{path}: {err}") from None
        return frame

    def _sibling_buffer(self, path: Path, buffer: str) -> torch.Tensor:
        """``buffer`` from ``<tttt>.<buffer>.exr``: its layer, else its plain channels."""
        sibling = self._sibling(path, buffer)
        if not sibling.is_file():
            raise FileFormatError(
                f"{path}: expected buffer {buffer!r} (the manifest's buffers) as its layer or in "
                f"{sibling.name}, got neither"
            )
        self.check_file(sibling)
        layers = read_exr(sibling)
        channels = AUX_BUFFERS[buffer]
        if buffer in layers:
            return layers[buffer]
        if "color" in layers and channels == 3:
            return layers["color"]
        if len(layers) == 1 and next(iter(layers.values())).shape[0] == channels:
            return next(iter(layers.values()))
        for names in _PLAIN.get(channels, ()):
            if set(layers) == set(names):
                return torch.cat([layers[n] for n in names])
        raise FileFormatError(
            f"{sibling}: expected buffer {buffer!r} ({channels} channels) as its layer or plain "
            f"channels, got layers {', '.join(sorted(layers))}"
        )

    def frame(self, method: str, seed_set: str, t: int) -> Frame:
        """The noisy frame ``t`` of ``method`` in ``seed_set`` (the manifest's buffers only)."""
        return self.read_file(self.frame_path(method, seed_set, t))

    def reference(self, t: int) -> Frame:
        """The reference of frame ``t`` (of frame 0 in a static folder)."""
        return self.read_file(self.reference_path(t), reference=True)

    def fingerprint(self) -> str:
        """A short hash of the manifest and every reference file: the records' reference
        version."""
        digest = hashlib.sha256((self.root / MANIFEST).read_bytes())
        for path in sorted(self.path(REFERENCE).glob("*.exr")):
            digest.update(path.name.encode() + path.read_bytes())
        return f"eval-{digest.hexdigest()[:12]}"


def reference_frames(m: Manifest) -> range:
    """The frames whose references a measurement reads: the measured ones, and the one before
    them when the coherent region is measured on moving frames (its disocclusion test)."""
    before = "coherent" in m.regions and not m.static
    return range(m.warmup - 1 if before else m.warmup, m.warmup + m.frames)


def _missing(paths: list[Path], what: str) -> FileFormatError:
    first = paths[0]
    more = f" (and {len(paths) - 1} more)" if len(paths) > 1 else ""
    return FileFormatError(f"{first}: expected {what} the manifest implies, got no such file{more}")


def check_folder(
    folder: FrameFolder, frames: dict[str, list[str]], times: range, *, pixels: bool = False
) -> None:
    """Check, before reading any pixel, every file a measurement will read: ``frames`` maps each
    method to its seed-set folders, ``times`` the frame indices; plus the references of the
    measured frames. With ``pixels``, then read every one of them as the measurement will
    (:meth:`FrameFolder.frame`, :meth:`FrameFolder.reference`) and drop it: a truncated file,
    missing channels or a non-finite pixel is refused before anything is written.

    Raises:
        FileFormatError: a missing frame or reference (one line: the first, and how many more),
            or a file that is not an EXR (with ``pixels``: one that cannot be read, or lacks
            the colour or a buffer the manifest names).
        ShapeError: a file whose header declares another size than the manifest's.
        ValueRangeError: a path that leaves the folder (a symbolic link).
        NonFiniteError: with ``pixels``, a NaN or infinite value.
    """
    refs = sorted({folder.reference_path(t) for t in reference_frames(folder.manifest)})
    absent = [p for p in refs if not p.is_file()]
    if absent:
        raise _missing(absent, "a reference")
    noisy = [folder.frame_path(k, s, t) for k, sets in frames.items() for s in sets for t in times]
    absent = [p for p in noisy if not p.is_file()]
    if absent:
        raise _missing(absent, "a frame")
    for path in [*refs, *noisy]:
        folder.check_file(path)
    if pixels:
        for path in refs:
            folder.read_file(path, reference=True)
        for path in noisy:
            folder.read_file(path)

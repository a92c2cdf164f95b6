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

Not for: measuring (:mod:`benchmarks.commands.eval.evaluate`).
"""

from __future__ import annotations

import dataclasses
import hashlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import torch

from bnerr.errors import (
    FileFormatError,
    NonFiniteError,
    ShapeError,
    ValueRangeError,
    check_finite,
)
from bnerr.frame import Frame
from bnerr.io import exr_size, read_exr, read_frame
from bnerr.metrics.regions import REGION_BUFFERS
from bnerr.schemas.documents import parse, read
from bnerr.schemas.errors import validate
from bnerr.schemas.eval import AUX_BUFFERS, MAX_PIXELS, EvalManifest

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
#: The manifest's keys: name -> (required, what it holds); the model's, as docs/EVAL.md lists.
MANIFEST_KEYS: dict[str, tuple[bool, str]] = {
    key: (field.is_required(), field.description or "")
    for key, field in EvalManifest.model_fields.items()
}
_MAX_MANIFEST_BYTES = 1 << 20
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


def parse_manifest(data: dict[str, Any]) -> Manifest:
    """The :class:`Manifest` of a parsed TOML table (:class:`bnerr.schemas.eval.EvalManifest`);
    without ``regions``, all plus coherent where the buffers and a reference before the first
    measured frame allow.

    Raises:
        UnknownNameError: an unknown key (the message lists the known ones), buffer or region.
        ValueRangeError: a missing or bad value, or no method named ``white``.
    """
    m = validate(EvalManifest, data, ValueRangeError, "", source=MANIFEST)
    values = {key: value for key, value in m if key != "resolution"}
    if m.regions is None:
        coherent = (m.static or m.warmup >= 1) and set(REGION_BUFFERS["coherent"]) <= set(m.buffers)
        values["regions"] = ("all", "coherent") if coherent else ("all",)
    return Manifest(width=m.resolution[0], height=m.resolution[1], **values)


def load_manifest(folder: str | Path) -> Manifest:
    """The folder's ``manifest.toml``, checked (:func:`parse_manifest`).

    Raises:
        FileFormatError: no manifest, or not TOML.
    """
    path = Path(folder) / MANIFEST
    if not path.is_file():
        raise FileFormatError(f"{path}: expected the frame folder's manifest, got no such file")
    data = read(path, FileFormatError, _MAX_MANIFEST_BYTES)
    document = parse(data, "toml", str(path), FileFormatError, what="a TOML manifest")
    return parse_manifest(cast(dict, document))


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

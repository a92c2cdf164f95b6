"""Image I/O: OpenEXR for every buffer (float32, exact), PNG previews, atomic writes.

EXR channel names (one single-part scanline file, ZIP compression, which is lossless):

============  ==========================================  =====================
buffer        channels                                    ``[C, H, W]``
============  ==========================================  =====================
color         ``R G B``                                    ``[3, H, W]``
albedo        ``albedo.R albedo.G albedo.B``               ``[3, H, W]``
normal        ``normal.X normal.Y normal.Z``               ``[3, H, W]``
depth         ``depth.Z``                                  ``[1, H, W]``
motion        ``motion.X motion.Y``                        ``[2, H, W]``
object_id     ``object_id.Y``                              ``[1, H, W]``
variance      ``variance.R variance.G variance.B``         ``[3, H, W]``
any other     ``<name>.0 .. <name>.<C-1>``                 ``[C, H, W]``
============  ==========================================  =====================

These follow the layer convention of the OpenEXR documentation ("Technical Introduction",
channel names ``layer.channel``), so compositing tools show each buffer as a layer. When reading
a file written elsewhere, the channels of a layer are ordered by the first of these suffix
orders that they match: ``R G B A``, ``X Y Z``, ``U V``, integers in numeric order, else
alphabetically. Channels without a layer other than ``R G B`` (``A``, ``Y``, ``Z``, ...) become
one-channel buffers under their own name. HALF and UINT channels are converted to float32 (UINT
values above 2^24 lose precision); of a multi-part file only the first part is read.

An output file's suffix decides its format, in one place for every command that writes images:
:func:`image_format` maps ``.exr`` to an EXR (exact float32) and ``.png`` to a tone-mapped 8-bit
PNG preview, and refuses any other suffix with the list of accepted ones (before any work, so a
command calls it first); :func:`write_image` writes a Frame in the format its name says.

Every writer goes through :func:`atomic_write`: a crash or an exception never leaves a partial
file under the final name.

Not for: deep images, tiled or mip-mapped files, or anything but single-part scanline output.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import io
import json
import os
import struct
import sys
import tempfile
import warnings
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import BinaryIO

import numpy as np
import torch

from bnerr.color import TONEMAPS as _COLOR_TONEMAPS
from bnerr.color import srgb_encode
from bnerr.color import tonemap as _tonemap
from bnerr.errors import (
    BnerrError,
    DtypeError,
    FileFormatError,
    ShapeError,
    check_dtype,
    check_name,
    check_range,
    check_shape,
)
from bnerr.frame import BUFFERS, Frame
from bnerr.outputs import OutputPathError, temporary_name

__all__ = [
    "exr_size",
    "CHANNELS",
    "IMAGE_SUFFIXES",
    "TIMINGS_ATTRIBUTE",
    "TONEMAPS",
    "atomic_write",
    "image_format",
    "openexr_quiet",
    "read_exr",
    "read_frame",
    "write_exr",
    "write_frame",
    "write_image",
    "write_png",
]

#: Buffer name -> its EXR channel names, in tensor order. Other buffers use ``<name>.<k>``.
CHANNELS: dict[str, tuple[str, ...]] = {
    "color": ("R", "G", "B"),
    "albedo": ("albedo.R", "albedo.G", "albedo.B"),
    "normal": ("normal.X", "normal.Y", "normal.Z"),
    "depth": ("depth.Z",),
    "motion": ("motion.X", "motion.Y"),
    "object_id": ("object_id.Y",),
    "variance": ("variance.R", "variance.G", "variance.B"),
}

#: Output suffixes of image files and what each writes: ``.exr`` every buffer exactly
#: (:func:`write_frame`), ``.png`` a tone-mapped sRGB preview of the color (:func:`write_png`).
IMAGE_SUFFIXES: tuple[str, ...] = (".exr", ".png")

#: Tone-map names of :func:`write_png` (:data:`bnerr.color.TONEMAPS`, sorted).
TONEMAPS = tuple(sorted(_COLOR_TONEMAPS))

#: Header attribute that holds a Frame's timings (JSON, milliseconds by stage).
TIMINGS_ATTRIBUTE = "bnerr_timings"

_SUFFIX_ORDERS = (("R", "G", "B", "A"), ("X", "Y", "Z"), ("U", "V"))
#: Bytes of OpenEXR's own stderr kept by :func:`openexr_quiet`.
_CAUGHT_LIMIT = 4096


# ------------------------------------------------------------------------------------------------
# Atomic writes


def _check_path(path: object, name: str = "path") -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise DtypeError(f"{name}: expected a str or os.PathLike, got {type(path).__name__}")
    return Path(path)


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, *, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success rename it over ``path``.

    The temporary file lives in the same folder (so that :func:`os.replace` is an atomic rename
    on POSIX and Windows), is named by :func:`bnerr.outputs.temporary_name` (hidden, with the
    writer's process id, so that :func:`bnerr.outputs.clean_stale_temporaries` can remove what a
    killed process left) and ends with ``suffix`` (default: ``path``'s suffix), so that writers
    that choose the format by extension still work. If the body raises, the temporary file is
    removed and nothing under ``path`` changes; a failure of that cleanup (a read-only file
    system) is ignored, so the body's own error is the one raised. Readers never see a
    half-written file.

    Raises:
        FileFormatError: the folder does not exist, or the body wrote nothing.
        OutputPathError: the file system refused the write or the rename (the message names
            ``path`` and says why in one line).
    """
    path = _check_path(path)
    if not path.parent.is_dir():
        raise FileFormatError(f"{path}: cannot write, folder {path.parent} does not exist")
    tmp = temporary_name(path, path.suffix if suffix is None else suffix)
    try:
        yield tmp
        if not tmp.exists():
            raise FileFormatError(f"{path}: the writer created nothing at {tmp.name}")
        os.replace(tmp, path)
    except BaseException as err:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
        if isinstance(err, OSError) and not isinstance(err, BnerrError):
            reason = err.strerror or str(err).splitlines()[0]
            raise OutputPathError(f"{path}: expected a writable file, got {reason}") from err
        raise


# ------------------------------------------------------------------------------------------------
# EXR


def _channel_names(name: str, channels: int) -> tuple[str, ...]:
    if name in CHANNELS:
        return CHANNELS[name]
    return tuple(f"{name}.{k}" for k in range(channels))


def _check_buffers(buffers: object) -> dict[str, torch.Tensor]:
    """Check a ``name -> [C, H, W] float32`` dict: one size for all, known names' channels."""
    if not isinstance(buffers, Mapping) or not buffers:
        raise DtypeError(
            f"buffers: expected a non-empty dict of name -> [C, H, W] tensor, got {buffers!r:.80}"
        )
    size: tuple[int, int] | None = None
    for name, tensor in buffers.items():
        if not isinstance(name, str) or not name:
            raise DtypeError(f"buffers: expected non-empty str names, got {name!r}")
        label = f"buffers[{name!r}]"
        spec = f"{len(CHANNELS[name])} H W" if name in CHANNELS else "C H W"
        got = check_shape(tensor, spec, label)
        check_dtype(tensor, torch.float32, label)
        if got["H"] < 1 or got["W"] < 1:
            raise ShapeError(f"{label}: expected H, W >= 1, got shape {list(tensor.shape)}")
        if size is None:
            size = (got["H"], got["W"])
        elif size != (got["H"], got["W"]):
            raise ShapeError(
                f"{label}: expected H x W = {size[0]} x {size[1]} like the first buffer, "
                f"got {got['H']} x {got['W']}"
            )
    return dict(buffers)


def _write_exr(path: Path, buffers: dict[str, torch.Tensor], attributes: dict[str, str]) -> None:
    import OpenEXR  # a compiled extension: imported only by the EXR functions

    channels: dict[str, np.ndarray] = {}
    for name, tensor in buffers.items():
        pixels = tensor.detach().cpu().numpy()
        for channel, plane in zip(_channel_names(name, pixels.shape[0]), pixels):
            # OpenEXR reads the array's memory as row-major without looking at its strides: a
            # non-contiguous view would be written scrambled.
            channels[channel] = np.ascontiguousarray(plane)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}
    with atomic_write(path) as tmp:
        # File() turns the values of the dict it gets into Channel objects: give it its own.
        try:
            OpenEXR.File(header, dict(channels)).write(str(tmp))
        except RuntimeError as err:  # OpenEXR's word for a full disk or a read-only folder
            raise _exr_write_error(path, err) from err


#: The system's reasons OpenEXR quotes at the end of a write error, and their errno.
_REASONS = {os.strerror(code): code for code in (errno.ENOSPC, errno.EROFS, errno.EACCES)}


def _exr_write_error(path: Path, err: RuntimeError) -> OutputPathError:
    """OpenEXR's write error as an OutputPathError naming ``path`` and the system's reason
    (``... "<tmp>". No space left on device.`` -> ``No space left on device``, its ``errno``
    set), else its first line."""
    text = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
    reason = text.rstrip(".").rsplit('". ', 1)[-1]
    error = OutputPathError(f"{path}: expected a writable file, got {reason}")
    error.errno = _REASONS.get(reason)
    return error


def write_exr(
    path: str | os.PathLike,
    buffers: Mapping[str, torch.Tensor],
    attributes: Mapping[str, str] | None = None,
) -> None:
    """Write named ``[C, H, W]`` float32 buffers to one EXR file, exactly (see the module table).

    Args:
        path: the file to write (atomically: see :func:`atomic_write`).
        buffers: buffer name -> ``[C, H, W]`` float32 tensor on any device; all share H and W.
            Known names (``color``, ``albedo``, ...) must have their channel count.
        attributes: optional extra string attributes for the header (name -> value).

    Raises:
        ShapeError, DtypeError: a buffer of the wrong shape or dtype, or a bad name.
        FileFormatError: the folder does not exist.
    """
    path = _check_path(path)
    buffers = _check_buffers(buffers)
    attributes = dict(attributes or {})
    for key, value in attributes.items():
        if not isinstance(key, str) or not isinstance(value, str):
            raise DtypeError(f"attributes: expected str -> str, got {key!r}: {value!r:.40}")
    _write_exr(path, buffers, attributes)


def _order(layer: str, suffixes: list[str], path: Path) -> list[str]:
    """The suffixes of one layer in tensor order (see the module docstring)."""
    if layer in CHANNELS:
        want = [c.rpartition(".")[2] for c in CHANNELS[layer]]
        if sorted(suffixes) != sorted(want):
            raise FileFormatError(
                f"{path}: layer {layer!r} expected channels {', '.join(want)}, "
                f"got {', '.join(sorted(suffixes))}"
            )
        return want
    for order in _SUFFIX_ORDERS:
        if set(suffixes) <= set(order):
            return [s for s in order if s in suffixes]
    if all(s.isdigit() for s in suffixes):
        return sorted(suffixes, key=int)
    return sorted(suffixes)


def _group(names: list[str], path: Path) -> dict[str, list[str]]:
    """Channel names -> buffer name -> channel names in tensor order."""
    layers: dict[str, list[str]] = {}
    for channel in names:
        layer, _, suffix = channel.rpartition(".")
        if not layer:  # no layer: R, G, B are the color, anything else is its own buffer
            layer, suffix = ("color", channel) if channel in ("R", "G", "B") else (channel, "")
        layers.setdefault(layer, []).append(suffix)
    if "color" in layers and len(layers["color"]) < 3:  # an incomplete RGB: plain channels
        for suffix in layers.pop("color"):
            layers[suffix] = [""]
    grouped = {}
    for layer, suffixes in layers.items():
        if suffixes == [""]:
            grouped[layer] = [layer]
            continue
        order = _order(layer, suffixes, path)
        if layer == "color":
            grouped[layer] = order
        else:
            grouped[layer] = [f"{layer}.{s}" for s in order]
    return grouped


@contextlib.contextmanager
def openexr_quiet(path: str | os.PathLike) -> Iterator[list[str]]:
    """Run the ``with`` block (calls into OpenEXR) with the process's stdout and stderr caught
    (file descriptors 1 and 2, and Python's ``sys.stdout`` and ``sys.stderr``): on a corrupt file
    the C library prints its own line to stderr and the binding "Warning: Exception raised
    reading pixel data" to stdout, before the exception that bnerr turns into its one line.

    Yields a list that holds, once the block ends, what was printed as one line (empty if
    nothing). If the block raises, the caller quotes it in its error; if it succeeds, what was
    printed is passed on as one warning naming ``path``: nothing is lost, and nothing is printed
    past bnerr's own lines.
    """
    said: list[str] = []
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            stream.flush()
    _flush_c_streams()  # what was printed before is not caught
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    python = io.StringIO()  # the binding may print through Python's sys.stdout (py::print)
    try:
        with (
            tempfile.TemporaryFile() as caught,
            contextlib.redirect_stdout(python),
            contextlib.redirect_stderr(python),
        ):
            for fd in saved:
                os.dup2(caught.fileno(), fd)
            try:
                yield said
            finally:
                _flush_c_streams()  # the C++ binding's lines sit in C's stdout buffer until then
                for fd, copy in saved.items():
                    os.dup2(copy, fd)
                caught.seek(0)
                text = caught.read(_CAUGHT_LIMIT).decode("utf-8", "replace")
                text += python.getvalue()[:_CAUGHT_LIMIT]
                said.append(" / ".join(t.strip() for t in text.splitlines() if t.strip()))
    finally:
        for copy in saved.values():
            os.close(copy)
    if said[0]:  # a read that succeeded but printed: one warning, after the streams are back
        warnings.warn(f"{path}: OpenEXR said: {said[0]}", stacklevel=3)


def _flush_c_streams() -> None:
    """``fflush(NULL)``: C's stdio buffers (where ``std::cout`` writes go) onto their files."""
    with contextlib.suppress(OSError, AttributeError, TypeError):
        ctypes.CDLL(None).fflush(None)


def _said(said: list[str]) -> str:
    """``; OpenEXR said: ...`` for an error message, or nothing."""
    return f"; OpenEXR said: {said[0]}" if said and said[0] else ""


def _read_exr(path: str | os.PathLike) -> tuple[dict[str, torch.Tensor], dict]:
    """Buffers and header of an EXR file; every failure is a FileFormatError naming the file."""
    import OpenEXR

    path = _check_path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: no such file")
    said: list[str] = []
    try:
        with openexr_quiet(path) as said:
            if not OpenEXR.isOpenExrFile(str(path)):
                raise FileFormatError(f"{path}: not an OpenEXR file (no EXR magic number)")
            exr = OpenEXR.File(str(path), separate_channels=True)
            header = exr.header()
            channels = {name: channel.pixels for name, channel in exr.channels().items()}
    except FileFormatError:
        raise
    except Exception as error:  # the binding raises RuntimeError or ValueError on corrupt data
        reason = str(error).splitlines()[0] if str(error) else ""
        raise FileFormatError(
            f"{path}: corrupt or truncated OpenEXR file ({type(error).__name__}: "
            f"{reason}){_said(said)}"
        ) from error
    if not channels:
        raise FileFormatError(f"{path}: the OpenEXR file holds no channels")
    buffers = {}
    for name, members in _group(list(channels), path).items():
        planes = [np.asarray(channels[c], dtype=np.float32) for c in members]
        buffers[name] = torch.from_numpy(np.stack(planes))
    return buffers, header


def read_exr(path: str | os.PathLike) -> dict[str, torch.Tensor]:
    """Read an EXR file into named ``[C, H, W]`` float32 CPU tensors (see the module table).

    Raises:
        FileFormatError: the file is missing, not an EXR, corrupt or truncated, or a known
            layer has the wrong channels; the message names the file.
    """
    return _read_exr(path)[0]


# ------------------------------------------------------------------------------------------------
# Frames


def write_frame(path: str | os.PathLike, frame: Frame) -> None:
    """Write a :class:`~bnerr.frame.Frame`: its buffers as EXR layers, its timings as JSON in the
    header attribute ``bnerr_timings``."""
    if not isinstance(frame, Frame):
        raise DtypeError(f"frame: expected a bnerr.frame.Frame, got {type(frame).__name__}")
    timings = json.dumps({str(k): float(v) for k, v in frame.timings.items()}, sort_keys=True)
    write_exr(path, frame.buffers(), {TIMINGS_ATTRIBUTE: timings})


def read_frame(path: str | os.PathLike) -> Frame:
    """Read a Frame written by :func:`write_frame` (or any EXR with ``R G B``).

    Layers that are not Frame buffers are ignored; missing timings read as ``{}``.

    Raises:
        FileFormatError: as :func:`read_exr`, or the file has no ``R G B`` channels, or its
            timings attribute is not a JSON object of numbers.
    """
    buffers, header = _read_exr(path)
    if "color" not in buffers:
        raise FileFormatError(
            f"{path}: expected channels R, G, B for the frame's color, "
            f"got layers {', '.join(sorted(buffers))}"
        )
    known = {name: t for name, t in buffers.items() if name in BUFFERS or name == "variance"}
    timings: dict[str, float] = {}
    if TIMINGS_ATTRIBUTE in header:
        try:
            raw = json.loads(header[TIMINGS_ATTRIBUTE])
            timings = {str(k): float(v) for k, v in raw.items()}
        except (TypeError, ValueError, AttributeError) as error:
            raise FileFormatError(
                f"{path}: header attribute {TIMINGS_ATTRIBUTE} is not a JSON object of numbers "
                f"({error})"
            ) from error
    try:
        return Frame(**known, timings=timings, own_denoised={})
    except (ShapeError, DtypeError) as error:
        raise FileFormatError(f"{path}: not a valid frame ({error})") from error


# ------------------------------------------------------------------------------------------------
# PNG previews


def write_png(
    path: str | os.PathLike,
    color: torch.Tensor,
    exposure: float = 0.0,
    tonemap: str = "aces",
) -> None:
    """Write an 8-bit sRGB PNG preview of linear radiance ``color [3, H, W]`` float32.

    ``value = srgb(tonemap(color * 2^exposure))``, rounded to 8 bits, an RGB PNG whatever the
    suffix of ``path``; encoded by Pillow. Negative values and NaN show as 0,
    +inf as white: a preview must not fail on a firefly. ``tonemap`` is ``"aces"`` (Narkowicz's
    fit), ``"reinhard"`` or ``"clamp"`` (:func:`bnerr.color.tonemap`).

    Not for: data; previews lose range and precision. Use :func:`write_exr` for anything that is
    measured.
    """
    path = _check_path(path)
    check_shape(color, "3 H W", "color")
    check_dtype(color, torch.float32, "color")
    exposure = check_range(exposure, "exposure", -64.0, 64.0)
    check_name(tonemap, TONEMAPS, "tonemap")
    if color.shape[1] < 1 or color.shape[2] < 1:
        raise ShapeError(f"color: expected H, W >= 1, got shape {list(color.shape)}")
    linear = torch.nan_to_num(color.detach().cpu().double(), nan=0.0, posinf=1e30, neginf=0.0)
    linear = (linear * 2.0**exposure).clamp(min=0)
    # bnerr.color's tone map and sRGB curve, evaluated in float64 here (the PNG files written so
    # far were, and stay byte-identical); bnerr.color.preview_u8 is the float32 twin.
    encoded = srgb_encode(_tonemap(linear, tonemap).clamp(0, 1))
    pixels = (encoded * 255).round().to(torch.uint8).permute(1, 2, 0).contiguous().numpy()
    # Pillow itself (what scikit-image's imsave called through imageio, the same bytes): 25 ms to
    # import where skimage.io took 270 ms, a tenth of a `bnerr render` process's own time.
    from PIL import Image  # needed here only

    with atomic_write(path, suffix=".png") as tmp:
        Image.fromarray(pixels).save(tmp, format="PNG")


# ------------------------------------------------------------------------------------------------
# Output names decide the format


def image_format(
    path: str | os.PathLike, name: str = "--out", accepted: tuple[str, ...] = IMAGE_SUFFIXES
) -> str:
    """The lower-case suffix of ``path`` if it is one of ``accepted`` (default
    :data:`IMAGE_SUFFIXES`), which decides the format a writer uses.

    Commands call it before any work, so that a name the writers cannot honour (``result.tiff``,
    ``result``) is refused at once instead of after minutes of rendering, and so that a ``.png``
    name never receives EXR bytes.

    Raises:
        FileFormatError: ``"<name> <path>: expected a name ending in .exr or .png, got '.tiff'"``.
    """
    path = _check_path(path, name)
    suffix = path.suffix.lower()
    if suffix not in accepted:
        got = repr(suffix) if suffix else "no suffix"
        raise FileFormatError(
            f"{name} {path}: expected a name ending in {' or '.join(accepted)}, got {got}"
        )
    return suffix


def write_image(
    path: str | os.PathLike, frame: Frame, *, exposure: float = 0.0, tonemap: str = "aces"
) -> None:
    """Write ``frame`` in the format ``path``'s suffix names (:func:`image_format`): ``.exr``
    every buffer and the timings (:func:`write_frame`, reads back with :func:`read_frame`),
    ``.png`` a preview of the color (:func:`write_png` with ``exposure`` and ``tonemap``).

    Raises:
        FileFormatError: any other suffix (nothing is written).
    """
    if not isinstance(frame, Frame):
        raise DtypeError(f"frame: expected a bnerr.frame.Frame, got {type(frame).__name__}")
    if image_format(path, "path") == ".png":
        write_png(path, frame.color, exposure=exposure, tonemap=tonemap)
    else:
        write_frame(path, frame)


_EXR_MAGIC = b"\x76\x2f\x31\x01"
_HEADER_LIMIT = 1 << 20  # bytes of attributes read before the data window must have come


def _attribute_string(handle: BinaryIO, path: Path) -> str:
    """A null-terminated attribute name or type (at most 255 bytes, as OpenEXR's long names)."""
    raw = bytearray()
    while (byte := handle.read(1)) not in (b"", b"\x00"):
        raw += byte
        if len(raw) > 255:
            break
    if byte != b"\x00":
        raise FileFormatError(f"{path}: expected an OpenEXR header, got a truncated attribute")
    return raw.decode("latin-1")


def exr_size(path: Path) -> tuple[int, int]:
    """``(width, height)`` of an EXR's data window, from its header alone: the attributes are
    parsed here (OpenEXR's own reader would size its tables from a window first), no pixel read.

    Raises:
        FileFormatError: not an EXR, or a header without a data window.
    """
    with open(path, "rb") as handle:
        if handle.read(4) != _EXR_MAGIC or len(handle.read(4)) != 4:
            raise FileFormatError(f"{path}: expected an OpenEXR file, got no EXR magic number")
        while handle.tell() < _HEADER_LIMIT and (name := _attribute_string(handle, path)):
            kind = _attribute_string(handle, path)
            (size,) = struct.unpack("<i", handle.read(4).rjust(4, b"\xff"))
            if not 0 <= size <= _HEADER_LIMIT:  # read() would allocate the size first
                break
            value = handle.read(size)
            if name == "dataWindow" and kind == "box2i" and len(value) == 16:
                x0, y0, x1, y1 = struct.unpack("<4i", value)
                return x1 - x0 + 1, y1 - y0 + 1
    raise FileFormatError(f"{path}: expected an OpenEXR header with a dataWindow, got none")

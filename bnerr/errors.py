"""Typed errors and the input checks that raise them.

Every public function of bnerr, renderers, denoisers and benchmarks checks its input at the
boundary with these helpers (never with ``assert``, which ``python -O`` removes) and raises one of
these errors, whose message names what was expected and what came. Private helpers trust their
callers.

The error classes also derive from the matching builtin (``ValueError``, ``TypeError``,
``OSError``, ``ImportError``) so that callers who catch the builtin keep working.

A missing optional dependency is always a :class:`MissingExtraError` (Mitsuba and its LLVM
library, OIDN, FLIP, Ray, imageio's ffmpeg), whose message names the extra that provides it and
the command that installs it (:data:`EXTRAS`); the CLI prints it as one line with exit code 2.
A missing required dependency (an environment installed before it was added) is a
:class:`MissingDependencyError`, printed the same way.
"""

from __future__ import annotations

import os
from collections.abc import Collection, Iterable
from pathlib import Path

import torch

__all__ = [
    "BnerrError",
    "DtypeError",
    "EXTRAS",
    "ExternalProcessError",
    "FileFormatError",
    "MemoryLimitError",
    "MissingDependencyError",
    "MissingExtraError",
    "NonFiniteError",
    "PluginError",
    "SceneFileError",
    "ShapeError",
    "UnknownNameError",
    "FLOAT_DTYPES",
    "INT_DTYPES",
    "ValueRangeError",
    "available_memory",
    "available_devices",
    "check_device",
    "check_dtype",
    "check_finite",
    "check_memory",
    "check_name",
    "check_offset",
    "check_positive_int",
    "check_range",
    "check_shape",
    "check_tensor",
    "toml_reason",
]


#: The floating dtypes bnerr's ops accept (computations run in float32 unless said otherwise).
FLOAT_DTYPES: tuple[torch.dtype, ...] = (
    torch.float16,
    torch.bfloat16,
    torch.float32,
    torch.float64,
)
#: The signed integer dtypes bnerr's ops accept where an integer tensor is expected.
INT_DTYPES: tuple[torch.dtype, ...] = (torch.int8, torch.int16, torch.int32, torch.int64)


class BnerrError(Exception):
    """Base class of every error bnerr raises on bad input."""


class ShapeError(BnerrError, ValueError):
    """A tensor has the wrong number of dimensions or the wrong size."""


class DtypeError(BnerrError, TypeError):
    """A tensor (or value) has the wrong type or dtype."""


class ValueRangeError(BnerrError, ValueError):
    """A number lies outside its allowed range (a negative size, a block size of 9, ...)."""


class NonFiniteError(BnerrError, ValueError):
    """A tensor that must be finite holds NaN or infinity."""


class UnknownNameError(BnerrError, ValueError):
    """A name (scene, sampler, denoiser, strategy, suite) is not registered."""


class PluginError(BnerrError, ImportError):
    """A plug-in (a ``pkg.mod:attr`` or ``file.py:Name`` spec, or an installed entry point)
    cannot be used: its import fails, the attribute is missing, the object is of the wrong kind,
    or building it raises. The one-line message names the plug-in, its distribution and what was
    expected (:mod:`bnerr.plugins`)."""


#: Optional extra (of pyproject.toml, or what an extra needs beside it) -> the command that
#: installs it. ``make`` installs every pip extra (and libllvm19 when run as root on Debian).
EXTRAS: dict[str, str] = {
    "reference": "pip install '.[reference]' or make",
    "cluster": "pip install '.[cluster]' or make",
    "llvm": "apt-get install libllvm19 (make does it as root on Debian), or point "
    "DRJIT_LIBLLVM_PATH at a libLLVM >= 19",
    "ffmpeg": "pip install 'imageio-ffmpeg>=0.8,<0.9' (a bnerr dependency: pip install . or make)",
    "cycles": "make cycles (a Python 3.11 venv .venv-cycles with bpy==4.5.4; bpy pins numpy<2, "
    "so it cannot share bnerr's environment), or point BNERR_BPY_PYTHON at a Python with bpy",
}


class MissingExtraError(BnerrError, ImportError):
    """An optional dependency is not installed (or not usable): one class for every extra.

    The message reads ``"<what>: expected the optional extra '<extra>', which provides <provides>
    (install: <install>), got <got>"``; ``extra`` and ``install`` are kept as attributes.

    Args:
        what: the feature that needs it (``"oidn"``, ``"flip"``, ``"--ray"``, ...).
        extra: a key of :data:`EXTRAS` (``"reference"``, ``"cluster"``, ``"llvm"``, ``"ffmpeg"``).
        provides: what the extra brings that is missing (``"pyoidn"``, ``"ray"``, ...).
        got: what was found instead (the import error's text, an old version, ...).
    """

    def __init__(self, what: str, extra: str, provides: str, got: str) -> None:
        check_name(extra, EXTRAS, "optional extra")
        self.what, self.extra, self.install = what, extra, EXTRAS[extra]
        super().__init__(
            f"{what}: expected the optional extra '{extra}', which provides {provides} "
            f"(install: {self.install}), got {got}"
        )

    def __reduce__(self) -> tuple[object, ...]:  # picklable (Ray and multiprocessing send it)
        return (_rebuild_missing_extra, (str(self), self.what, self.extra))


class MissingDependencyError(BnerrError, ImportError):
    """A required dependency is not installed (an environment set up before it was added).

    The message reads ``"<what>: expected the package <package> (a dependency of bnerr; install:
    pip install <package>), got <got>"``.
    """

    def __init__(self, what: str, package: str, got: str) -> None:
        self.what, self.package = what, package
        super().__init__(
            f"{what}: expected the package {package} (a dependency of bnerr; install: "
            f"pip install {package}), got {got}"
        )

    def __reduce__(self) -> tuple[object, ...]:  # picklable (Ray and multiprocessing send it)
        return (type(self), (self.what, self.package, str(self).rsplit(", got ", 1)[-1]))


def _rebuild_missing_extra(message: str, what: str, extra: str) -> MissingExtraError:
    err = MissingExtraError.__new__(MissingExtraError)
    Exception.__init__(err, message)
    err.what, err.extra, err.install = what, extra, EXTRAS[extra]
    return err


class FileFormatError(BnerrError, OSError):
    """A file is missing, unreadable, corrupt or not in the expected format."""


class MemoryLimitError(BnerrError, MemoryError):
    """A size (resolution, batch, kernel, radius) needs more memory than the machine has."""


class ExternalProcessError(BnerrError, RuntimeError):
    """An external program (an executable denoiser, :mod:`denoisers.external`; a renderer driven
    through the seed protocol, :mod:`renderers.external`; both run by :mod:`bnerr.external`) did
    not do its part: it would not start, exited with a non-zero status, ran past its time limit,
    or wrote no output or one of the wrong size, channels, type or with non-finite values. The
    first line names the program and its command and says what was expected; the last lines the
    program wrote to stderr follow it, indented."""


def check_tensor(x: object, name: str) -> torch.Tensor:
    """Raise :class:`DtypeError` unless ``x`` is a ``torch.Tensor``; return it."""
    if not isinstance(x, torch.Tensor):
        raise DtypeError(f"{name}: expected a torch.Tensor, got {type(x).__name__}")
    return x


def check_shape(x: torch.Tensor, spec: str, name: str) -> dict[str, int]:
    """Check ``x`` against a shape spec such as ``"H W"``, ``"C H W"`` or ``"3 H W"``.

    Letters bind sizes (the same letter must have the same size everywhere in the spec), digits
    require that exact size, ``*`` accepts any size. Returns the bound sizes, e.g.
    ``{"H": 64, "W": 32}``.
    """
    check_tensor(x, name)
    dims = spec.split()
    if x.ndim != len(dims):
        raise ShapeError(
            f"{name}: expected {len(dims)} dimensions [{', '.join(dims)}], "
            f"got {x.ndim} with shape {list(x.shape)}"
        )
    bound: dict[str, int] = {}
    for axis, (want, got) in enumerate(zip(dims, x.shape)):
        if want == "*":
            continue
        if want.isdigit():
            if int(want) != got:
                raise ShapeError(
                    f"{name}: expected shape [{', '.join(dims)}] with size {want} on axis {axis}, "
                    f"got shape {list(x.shape)}"
                )
        elif bound.setdefault(want, got) != got:
            raise ShapeError(
                f"{name}: expected shape [{', '.join(dims)}] ({want} equal on every axis), "
                f"got shape {list(x.shape)}"
            )
    return bound


def check_dtype(x: torch.Tensor, dtypes: torch.dtype | Iterable[torch.dtype], name: str) -> None:
    """Raise :class:`DtypeError` unless ``x.dtype`` is one of ``dtypes``."""
    check_tensor(x, name)
    allowed = (dtypes,) if isinstance(dtypes, torch.dtype) else tuple(dtypes)
    if x.dtype not in allowed:
        want = " or ".join(str(d).removeprefix("torch.") for d in allowed)
        raise DtypeError(
            f"{name}: expected dtype {want}, got {str(x.dtype).removeprefix('torch.')}"
        )


def _first_bad(bad: torch.Tensor) -> str:
    """Where the first True of ``bad`` lies: the pixel ``(y, x)`` in raster order for tensors of
    2 or more dimensions (the last two are H, W; any channel counts), else the flat index."""
    if bad.ndim == 0:
        return ""
    if bad.ndim == 1:
        return f", first at index {int(bad.to(torch.uint8).argmax())}"
    width = bad.shape[-1]
    pixels = bad.reshape(-1, bad.shape[-2] * width).any(dim=0)
    y, x = divmod(int(pixels.to(torch.uint8).argmax()), width)
    return f", first at pixel (y, x) = ({y}, {x})"


def check_finite(x: torch.Tensor, name: str) -> None:
    """Raise :class:`NonFiniteError` if ``x`` holds NaN or infinity: how many, and where the first
    one is (pixel ``(y, x)`` of a ``[..., H, W]`` tensor, in raster order).

    A finite sum proves every value finite (NaN and infinity propagate through a sum), so the
    common case costs one reduction instead of a boolean image and its ``any`` (a tenth of the
    time at 1080p); a sum that overflows falls back to the exact check."""
    if not x.is_floating_point() or bool(torch.isfinite(x.sum())):
        return
    bad = ~torch.isfinite(x)
    if bool(bad.any()):
        n_nan = int(torch.isnan(x).sum())
        n_inf = int(bad.sum()) - n_nan
        raise NonFiniteError(
            f"{name}: expected finite values, got {n_nan} NaN and {n_inf} infinite "
            f"of {x.numel()}{_first_bad(bad)}"
        )


def _meminfo_available() -> int | None:
    """``MemAvailable`` of ``/proc/meminfo`` in bytes, or None where there is no such file."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def _cgroup_headroom() -> int | None:
    """What the process's cgroup (v2) still allows, ``memory.max - memory.current``, or None."""
    try:
        root = Path("/sys/fs/cgroup")
        limit = (root / "memory.max").read_text().strip()
        if limit == "max":
            return None
        return max(int(limit) - int((root / "memory.current").read_text()), 0)
    except (OSError, ValueError):
        return None


def available_memory(device: torch.device | str | None = None) -> int:
    """Bytes a new allocation can use now, on ``device`` (default: host memory).

    Host: ``MemAvailable`` of ``/proc/meminfo`` (else ``os.sysconf`` physical pages times page
    size), lowered to the cgroup's headroom where a cgroup limit is set. CUDA: the free memory
    ``torch.cuda.mem_get_info`` reports.
    """
    if device is not None and torch.device(device).type == "cuda":
        return int(torch.cuda.mem_get_info(torch.device(device))[0])
    found = _meminfo_available()
    if found is None:
        try:
            found = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            found = 1 << 62  # unknown: do not refuse
    headroom = _cgroup_headroom()
    return found if headroom is None else min(found, headroom)


def _gib(nbytes: float) -> str:
    return f"{nbytes / 2**30:.3g} GiB" if nbytes >= 2**27 else f"{nbytes / 2**20:.3g} MiB"


def check_memory(
    nbytes: float, name: str, device: torch.device | str | None = None, *, fraction: float = 0.9
) -> None:
    """Refuse a computation whose estimated peak memory exceeds what ``device`` has available.

    Call it before allocating, with a rough estimate of the bytes the sizes need; the estimate is
    compared with ``fraction`` of :func:`available_memory` (the rest is kept for what the
    estimate leaves out).

    Raises:
        MemoryLimitError: ``"<name>: expected at most X of memory (of Y available), got an
            estimate of Z"``.
    """
    have = available_memory(device)
    if nbytes > fraction * have:
        raise MemoryLimitError(
            f"{name}: expected a size that fits in memory (at most {_gib(fraction * have)} of "
            f"the {_gib(have)} available), got an estimate of {_gib(nbytes)}"
        )


def available_devices() -> list[str]:
    """The torch devices this process can compute on: ``cpu``, then ``cuda:0`` .. ``cuda:N-1``
    where CUDA is available."""
    cuda = torch.cuda.device_count() if torch.cuda.is_available() else 0
    return ["cpu"] + [f"cuda:{i}" for i in range(cuda)]


def check_device(device: object, name: str = "device") -> torch.device:
    """``device`` (a ``torch.device`` or a string: ``cpu``, ``cuda``, ``cuda:N``) as a
    ``torch.device``, if this process can compute on it.

    Raises:
        DtypeError: neither a string nor a ``torch.device``.
        ValueRangeError: not a torch device, or one that is not available here; the message
            names the devices that are (:func:`available_devices`).
    """
    if not isinstance(device, (str, torch.device)):
        raise DtypeError(
            f"{name}: expected a torch.device or str, got {type(device).__name__} {device!r}"
        )
    have = available_devices()
    try:
        parsed = torch.device(device)
    except RuntimeError:
        raise ValueRangeError(
            f"{name}: expected a torch device ({', '.join(have)}), got {device!r}"
        ) from None
    index = 0 if parsed.index is None else parsed.index
    usable = parsed.type == "cpu" or (parsed.type == "cuda" and f"cuda:{index}" in have)
    if not usable:
        raise ValueRangeError(
            f"{name}: expected an available device ({', '.join(have)}), got {device!s}"
        )
    return parsed


def check_positive_int(value: object, name: str, *, minimum: int = 1) -> int:
    """Return ``value`` as an int if it is an integer >= ``minimum``; raise otherwise."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise DtypeError(f"{name}: expected an integer, got {type(value).__name__} {value!r}")
    if value < minimum:
        raise ValueRangeError(f"{name}: expected an integer >= {minimum}, got {value}")
    return value


def check_range(value: object, name: str, lo: float, hi: float) -> float:
    """Return ``value`` if ``lo <= value <= hi``; raise :class:`ValueRangeError` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DtypeError(f"{name}: expected a number, got {type(value).__name__} {value!r}")
    if not lo <= value <= hi:
        raise ValueRangeError(f"{name}: expected a value in [{lo}, {hi}], got {value}")
    return value


def check_name(name: object, known: Collection[str], what: str) -> str:
    """Return ``name`` if it is one of ``known``; raise :class:`UnknownNameError` listing them."""
    if not isinstance(name, str) or name not in known:
        raise UnknownNameError(
            f"unknown {what} {name!r}: expected one of {', '.join(sorted(known))}"
        )
    return name


def check_offset(offset: object, name: str = "offset") -> tuple[int, int]:
    """A pair of Python integers ``(oy, ox)`` (a tuple or list; bools are refused)."""
    if (
        not isinstance(offset, (tuple, list))
        or len(offset) != 2
        or any(isinstance(o, bool) or not isinstance(o, int) for o in offset)
    ):
        raise DtypeError(f"{name}: expected a pair of integers (oy, ox), got {offset!r}")
    return offset[0], offset[1]


class SceneFileError(FileFormatError):
    """A scene file (:mod:`renderers.scene_file`) is unreadable, malformed or describes an invalid
    scene; the message names the file, then the line (syntax) or the key (meaning)."""


def toml_reason(err: ValueError, text: str) -> str:
    """The reason of ``tomllib``'s error ``err`` on ``text`` for a message, always naming its
    line: ``tomllib`` ends most with "(at line L, column C)", but an unclosed table or array
    with "(at end of document)", which this turns into the last line's number."""
    where = f"(at the end of the document, after line {len(text.splitlines())})"
    return str(err).replace("(at end of document)", where)

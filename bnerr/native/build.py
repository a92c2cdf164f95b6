"""Build, cache and load the native libraries: only a library this package built is ever loaded.

Each C source is package data of the package whose kernels it holds (``permute.c`` beside this
file: the seed permutation; ``filters.c`` and ``guided.c`` of :mod:`denoisers.native`), named by
that package and its file name, and is compiled with the system C compiler into a shared library
kept in a per-user cache folder, ``$BNERR_CACHE_DIR/native`` (default
``$XDG_CACHE_HOME/bnerr/native``, else ``~/.cache/bnerr/native``):

- **Key.** A library is looked up by a key that hashes the source, the flags, the compiler (its
  path, size and modification time, and any arguments in ``$CC``) and the host CPU's model and
  feature flags (``-march=native`` code must not run on another CPU).
- **The folder** is created with mode 0o700 and used only if it belongs to this user and no one
  else can write into it; otherwise the library is built in a private temporary folder for this
  process and not cached.
- **Record.** At build time the library is written under a name that holds its own content hash,
  and a sidecar ``<stem>_<key>.json`` (``permute_<key>.json`` for ``permute.c``) records that
  name and the library's SHA-256; both are written atomically (temporary file, then rename),
  the sidecar last.
- **Load.** A cached library is opened without following links and must be a regular file of
  this user; its bytes are read once, and only if their SHA-256 equals the recorded one are those
  very bytes written to a fresh private file (named by the hash) that the dynamic loader opens,
  so nothing can be swapped in between the check and the load. Anything else at the cached name
  (a planted file, a link, a half-written file) is rebuilt, never loaded.

Nothing here imports torch or the rest of bnerr, nor the packages whose sources it builds (it reads
their package data by name): the caller (:class:`bnerr.native.Library`) decides what to do with
the result.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import platform
import re
import shlex
import shutil
import stat
import subprocess
import tempfile
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

__all__ = [
    "FLAGS_NATIVE",
    "FLAGS_PORTABLE",
    "Compiler",
    "Outcome",
    "cache_dir",
    "find_compiler",
    "obtain",
    "open_library_bytes",
    "source_text",
]

# -ffp-contract=off: no fused multiply-add, so the luminance rounds like torch's separate ops.
FLAGS_NATIVE: tuple[str, ...] = (
    "-O3",
    "-march=native",
    "-ffp-contract=off",
    "-fPIC",
    "-shared",
    "-pthread",
)
FLAGS_PORTABLE: tuple[str, ...] = ("-O3", "-ffp-contract=off", "-fPIC", "-shared", "-pthread")
_BUILD_TIMEOUT_S = 300
_QUOTED_LINES = 4


@dataclass(frozen=True)
class Compiler:
    """The C compiler: ``program`` (an absolute path) and any extra arguments from ``$CC``."""

    program: str
    extra: tuple[str, ...]

    def identity(self) -> str:
        """Path, size and modification time of the program, and the extra arguments."""
        try:
            info = os.stat(self.program)
            mark = f"{os.path.realpath(self.program)} {info.st_size} {info.st_mtime_ns}"
        except OSError:
            mark = self.program
        return " ".join([mark, *self.extra])

    def __str__(self) -> str:
        return " ".join([self.program, *self.extra])


@dataclass
class Outcome:
    """What :func:`obtain` did.

    Attributes:
        library: the loaded library, or None.
        why: one line for :func:`bnerr.native.status`.
        warning: a message to show the user once, or None (a cache hit or a clean build).
        compiler_output: the compiler's stderr of the last build attempt (kept, not discarded).
    """

    library: ctypes.CDLL | None
    why: str
    warning: str | None = None
    compiler_output: str = ""


def source_text(package: str, name: str) -> str:
    """The C source ``name``, package data of the package ``package`` (a dotted name, e.g.
    ``"bnerr.native"``)."""
    return resources.files(package).joinpath(name).read_text()


def _stem(name: str) -> str:
    """The prefix of a source's cached files: ``permute.c`` -> ``permute``."""
    return Path(name).stem


def find_compiler() -> tuple[Compiler | None, str]:
    """``$CC`` (a program and optional arguments), else ``cc``, ``gcc`` or ``clang`` on the PATH.

    Returns the compiler, or None and why not.
    """
    words = shlex.split(os.environ.get("CC", ""))
    if words:
        found = shutil.which(words[0])
        if found is None:
            return None, f"the C compiler CC={words[0]!r} was not found"
        return Compiler(os.path.abspath(found), tuple(words[1:])), ""
    for name in ("cc", "gcc", "clang"):
        found = shutil.which(name)
        if found is not None:
            return Compiler(os.path.abspath(found), ()), ""
    return None, "no C compiler found (none of cc, gcc, clang on the PATH; set CC to one)"


def cpu_identity() -> str:
    """The host CPU's model and feature flags, so a ``-march=native`` build is never reused
    on another CPU."""
    parts = [platform.machine(), platform.processor()]
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        lines = []
    for prefix in ("model name", "flags", "Features", "CPU part"):
        parts += [line for line in lines if line.startswith(prefix)][:1]
    return "\n".join(parts)


def cache_dir() -> Path:
    """Where built libraries are cached (see the module docstring)."""
    base = os.environ.get("BNERR_CACHE_DIR")
    if base:
        return Path(base) / "native"
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "bnerr" / "native"


def _owner_ok(info: os.stat_result) -> bool:
    return not hasattr(os, "getuid") or info.st_uid == os.getuid()


def secure_dir(path: Path) -> str | None:
    """Create ``path`` (mode 0o700) if needed; None if it is a private folder of this user, else
    why it must not be used."""
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
        info = os.lstat(path)
    except OSError as err:
        return f"cannot create the cache folder {path} ({err})"
    if not stat.S_ISDIR(info.st_mode):
        return f"the cache folder {path} is not a folder (or is a link)"
    if not _owner_ok(info):
        return f"the cache folder {path} belongs to uid {info.st_uid}, not to this user"
    if info.st_mode & 0o022:
        mode = oct(stat.S_IMODE(info.st_mode))
        return f"the cache folder {path} is writable by group or others (mode {mode})"
    return None


def library_key(source: str, flags: tuple[str, ...], compiler: Compiler) -> str:
    """Hash of everything a built library depends on."""
    parts = [source, " ".join(flags), compiler.identity(), cpu_identity()]
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:20]


def _write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a private temporary file in the same folder."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _quote(stderr: str, returncode: int) -> str:
    """The compiler's first error lines (or its first lines when none says "error")."""
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    errors = [line for line in lines if "error" in line.lower()]
    picked = (errors or lines)[:_QUOTED_LINES]
    return " | ".join(picked) if picked else f"exit status {returncode}, no output"


def compile_library(
    compiler: Compiler, flags: tuple[str, ...], source: str, work: Path, name: str
) -> tuple[bytes | None, str, str]:
    """Compile ``source`` (the text of the file ``name``) in the folder ``work``;
    ``(library bytes or None, stderr, quote)``."""
    src, out = work / name, work / "library.so"
    src.write_text(source)
    command = [compiler.program, *compiler.extra, *flags, str(src), "-o", str(out)]
    try:
        proc = subprocess.run(
            command, capture_output=True, text=True, timeout=_BUILD_TIMEOUT_S, check=False
        )
    except (OSError, subprocess.TimeoutExpired) as err:
        return None, str(err), str(err)
    if proc.returncode != 0 or not out.is_file():
        return None, proc.stderr, _quote(proc.stderr, proc.returncode)
    return out.read_bytes(), proc.stderr, ""


def _open_private(path: Path) -> int | None:
    """An fd of ``path`` if it is a regular file of this user (links not followed), else None."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return None
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode) or not _owner_ok(info):
        os.close(fd)
        return None
    return fd


def _read_fd(fd: int) -> bytes:
    chunks = []
    while chunk := os.read(fd, 1 << 20):
        chunks.append(chunk)
    return b"".join(chunks)


def load_verified(path: Path, sha256: str) -> ctypes.CDLL | None:
    """Load ``path`` only if its bytes hash to ``sha256`` (None otherwise).

    The checked bytes themselves are loaded, from a private copy beside ``path`` that is removed
    once mapped (a unique name: the loader would return an already loaded library for a name it
    has seen). May raise OSError from the loader.
    """
    fd = _open_private(path)
    if fd is None:
        return None
    try:
        data = _read_fd(fd)
    finally:
        os.close(fd)
    if hashlib.sha256(data).hexdigest() != sha256:
        return None
    return open_library_bytes(data, path.parent, f".load-{sha256[:16]}-")


def open_library_bytes(data: bytes, folder: Path | None, prefix: str) -> ctypes.CDLL:
    """Open the shared library ``data`` through a private copy in ``folder`` (the system's temporary
    folder when None), unlinked once open: the loader keeps its mapping, and nobody can swap the
    file between a check of its bytes and the load."""
    handle, copy = tempfile.mkstemp(dir=folder, prefix=prefix, suffix=".so")
    try:
        with os.fdopen(handle, "wb") as f:
            f.write(data)
        return ctypes.CDLL(copy)
    finally:
        os.unlink(copy)


def _recorded(folder: Path, stem: str, key: str) -> tuple[Path, str] | None:
    """``(library path, sha256)`` from the sidecar of ``key``, or None if absent or malformed."""
    try:
        record = json.loads((folder / f"{stem}_{key}.json").read_text())
        name, sha = record["library"], record["sha256"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    pattern = rf"{re.escape(stem)}_{key}_[0-9a-f]{{16}}\.so"
    if not (isinstance(name, str) and re.fullmatch(pattern, name)):
        return None
    if not (isinstance(sha, str) and re.fullmatch(r"[0-9a-f]{64}", sha)):
        return None
    return folder / name, sha


def _store(
    folder: Path, stem: str, key: str, data: bytes, compiler: Compiler, flags: tuple[str, ...]
) -> tuple[Path, str]:
    """Write a built library and its sidecar (sidecar last); return ``(path, sha256)``."""
    sha = hashlib.sha256(data).hexdigest()
    path = folder / f"{stem}_{key}_{sha[:16]}.so"
    _write_atomic(path, data)
    record = {"library": path.name, "sha256": sha, "compiler": str(compiler), "flags": flags}
    _write_atomic(folder / f"{stem}_{key}.json", json.dumps(record, indent=1).encode())
    return path, sha


def _from_cache(folder: Path, stem: str, key: str) -> tuple[ctypes.CDLL | None, str | None]:
    """The cached library of ``key`` if its recorded hash matches; else ``(None, note)`` where
    ``note`` says what was found instead (None when nothing was cached)."""
    record = _recorded(folder, stem, key)
    if record is None:
        return None, None
    path, sha = record
    if not path.exists() and not path.is_symlink():
        return None, None
    library = load_verified(path, sha)
    if library is None:
        return None, f"ignored {path}: not the library this package built (hash mismatch)"
    return library, None


def _attempt(
    compiler: Compiler, flags: tuple[str, ...], source: str, folder: Path | None, name: str
) -> tuple[ctypes.CDLL | None, str, str, str, str | None]:
    """One build-or-reuse of the source file ``name`` (text ``source``) with ``flags``;
    ``(library, where, stderr, quote, note)``."""
    key, stem = library_key(source, flags, compiler), _stem(name)
    note = None
    if folder is not None:
        library, note = _from_cache(folder, stem, key)
        if library is not None:
            return library, f"cached at {folder}", "", "", None
    with tempfile.TemporaryDirectory(prefix="bnerr-native-") as tmp:
        data, stderr, quote = compile_library(compiler, flags, source, Path(tmp), name)
        if data is None:
            return None, "", stderr, quote, note
        place = Path(tmp) if folder is None else folder
        path, sha = _store(place, stem, key, data, compiler, flags)
        return load_verified(path, sha), f"built at {place}", stderr, "", note


def obtain(cost: str, package: str, name: str) -> Outcome:
    """Find a compiler, then reuse or build the library of the C source ``name``, package data of
    ``package`` (native flags, then portable ones).

    ``cost`` is what the torch path costs, quoted in the warnings.
    """
    compiler, missing = find_compiler()
    if compiler is None:
        return Outcome(None, missing, f"bnerr: {missing}; the torch path is used ({cost})")
    source = source_text(package, name)
    cached = cache_dir()
    unsafe = secure_dir(cached)
    folder: Path | None = cached
    notes = [] if unsafe is None else [f"{unsafe}; building in a private temporary folder"]
    if unsafe is not None:
        folder = None
    stderr = quote = ""
    for flags in (FLAGS_NATIVE, FLAGS_PORTABLE):
        try:
            library, where, stderr, quote, note = _attempt(compiler, flags, source, folder, name)
        except OSError as err:  # an unwritable cache, a library the loader refuses
            library, where, stderr, quote, note = None, "", str(err), str(err), None
        notes += [note] if note else []
        if library is not None:
            why = f"{where} with {compiler} {' '.join(flags)}"
            return Outcome(library, why, "bnerr: " + "; ".join(notes) if notes else None, stderr)
    why = f"the C compiler {compiler} could not build {name}: {quote}"
    warning = "; ".join([f"bnerr: {why}", *notes, f"the torch path is used ({cost})"])
    return Outcome(None, why, warning, stderr)

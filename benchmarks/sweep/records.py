"""The results file: one :class:`Record` per measured cell, one JSON object per line.

``<out>/cells.jsonl`` holds one line per cell, ``json.dumps(record.to_json(), sort_keys=True)``.
A sweep writes it whole and atomically once (:func:`write_records`), then appends each finished
run's lines in one write (:func:`append_records`), so that a run costs its own lines and not the
whole file again (rewriting grew with the square of the cell count: 8 % of the quality suite).
An interrupted sweep loses at most the run in progress; an append cut short leaves a last line
without its newline, which the resuming runner drops (``load_records(..., torn_tail=True)``) and
measures again. :func:`load_records` reads the file back; any other line that is not UTF-8, not
JSON or not a record raises :class:`~bnerr.errors.FileFormatError` naming the file and the line.

A finished folder may hold the same lines xz-compressed instead, ``<out>/cells.jsonl.xz``
(:func:`compress_records`, which ``bnerr bench`` calls once the report is written, so that the
committed ``results/`` stays small: on the quality suite's 12,096 records a thirtieth of the
bytes, 6.6 MB where gzip -9 left 13.0, its window of 32 KB being shorter than the 14 records of
a run, which share their raw metrics). Folders written before keep ``cells.jsonl.gz``, which is
read as well and turned into the xz archive the next time the folder is compressed.
:func:`load_records` and :func:`check_no_results` read any of them (the plain file first);
:func:`append_records` restores the plain file before appending, and :func:`write_records`
removes a compressed copy it supersedes.

**Precision.** A measured record is stored at the precision its measurement carries
(:meth:`Record.rounded`, which the runners apply before they keep a record, so the record in
memory is the record on disk): :data:`DIGITS` significant digits for every metric, correlation,
coverage, spectrum and floor (a relative step of at most 5e-4: a PSNR to 0.01 dB, an SSIM near 1
to 1e-4; far below one frame's Monte Carlo noise and the spread of any ratio over seed sets,
about 4e-2; whole numbers, the pixel counts, stay exact), and :data:`TIMING_DIGITS` for the
milliseconds, whose run-to-run spread is several per cent. Full ``repr`` precision had a
metric's float32 sums printed with 17 digits, of which the last ten are noise: 28 MB for the
quality suite's last looks (at 6 digits 4.6 MB of xz for its last looks at 8 seed sets, 8.0 MB
at up to 16; at 5, 6.9; at up to 32 seed sets 11.8 MB at 5 digits, 9.7 at 4, what lets them
into the 30 MB the committed results keep to). Records written before keep their digits
(nothing rounds them on reading, so older files rewrite byte for byte); ``bnerr bench
--report-only --compact`` rounds a finished folder's records in place.

The schema is the dataclasses below. Arrays are nested lists (JSON numbers); ``[S][F]`` is
seed set x measured frame:

- :class:`Record`: ``cell`` (:class:`benchmarks.sweep.plan.Cell`), ``dimensions`` (the scene's D),
  ``t`` (the measured frame indices ``[F]``), ``raw`` and ``den`` (metric name -> per-frame pairs
  ``[S][F][2]`` of :class:`bnerr.metrics.FrameMetrics`, before and after denoising),
  ``denoiser_params``, ``timings``, ``reference``, ``spectrum`` (``"raw"`` and ``"den"``;
  ``"coherent"``, the raw error's over the coherent region, when the run measured it) and
  ``crop`` (the crops file relative to the output folder, or None) and ``render_sampler`` (the
  sampler the strategy's renders used, ``strategy.sampler_name``: the cell's per-pixel
  ``sampler`` condition or the strategy's own; None, and absent on disk, in files written
  before it was recorded) and ``tcorr`` (``[S][F - 1]``: the raw error's correlation with the
  previous measured frame's along the motion, :func:`bnerr.metrics.temporal_correlation`, what
  temporal accumulation depends on; None, and absent on disk, in files written before it was)
  and ``coverage`` (``[S][F]``: the fraction of the pixels the cell's region covers in each
  measured frame; None, and absent on disk, for region ``all`` and in older files) and
  ``plugins`` (``"<group>:<name>"`` -> ``{"spec", "fingerprint"}`` of every plug-in the cell
  uses, :mod:`benchmarks.sweep.plugins`; None, and absent on disk, when it uses none) and
  ``looks`` (the seed-set counts of the group-sequential design its seed sets were added under,
  ``bnerr bench --until-resolved``, :mod:`bnerr.metrics.sequential`; None, and absent on disk,
  for a fixed number of seed sets) and ``device`` (where a cell off the CPU was measured,
  ``bnerr bench --device cuda``: ``{"device", "name", "torch", "cuda"}``,
  :func:`benchmarks.sweep.version.device_info`; None, and absent on disk, on the CPU, so CPU
  records, old ones among them, stay byte-identical).
  On disk the record also holds
  ``key`` (:meth:`Cell.key`), which is derived from ``cell``.
- :class:`Timings`: ``render_ms``, ``perm_ms``, ``denoise_ms``, each ``[S][F]`` milliseconds.
- :class:`ReferenceInfo`: ``spp``, ``floor`` (the mean variance of the reference's pixel means, or
  None) and ``version`` (the code version it was rendered with).
- :class:`Spectrum`: ``freq`` and ``power``, the error's radially averaged power spectrum.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import gzip
import json
import lzma
import os
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmarks.sweep.plan import Cell
from bnerr.errors import BnerrError, FileFormatError, ValueRangeError
from bnerr.io import atomic_write
from bnerr.outputs import OutputPathError

__all__ = [
    "ARCHIVES",
    "DIGITS",
    "LEGACY_ARCHIVE",
    "RESULTS_ARCHIVE",
    "RESULTS_FILE",
    "TIMING_DIGITS",
    "ReferenceInfo",
    "Record",
    "ResultsExistError",
    "Spectrum",
    "Timings",
    "append_records",
    "bare_key",
    "check_no_results",
    "collector_paused",
    "compact_records",
    "compress_records",
    "earlier_look",
    "final_records",
    "load_records",
    "write_records",
]

#: Name of the per-cell results file inside the output folder.
RESULTS_FILE = "cells.jsonl"
#: Name of its compressed form (:func:`compress_records`).
RESULTS_ARCHIVE = RESULTS_FILE + ".xz"
#: Name of the gzip-compressed form that folders written before the xz one keep (read only).
LEGACY_ARCHIVE = RESULTS_FILE + ".gz"
#: Both compressed forms, the current one first.
ARCHIVES = (RESULTS_ARCHIVE, LEGACY_ARCHIVE)
#: Significant digits of a record's measured values (:meth:`Record.rounded`).
DIGITS = 4
#: Significant digits of its timings.
TIMING_DIGITS = 3

#: Metric name -> ``[S][F][2]`` per-frame pairs.
MetricPairs = dict[str, list[list[list[float]]]]


class ResultsExistError(BnerrError, FileExistsError):
    """An output folder already holds finished cells that a fresh run would discard."""


@dataclass(frozen=True)
class Timings:
    """Per measured frame milliseconds, ``[S][F]`` each."""

    render_ms: list[list[float]]
    perm_ms: list[list[float]]
    denoise_ms: list[list[float]]


@dataclass(frozen=True)
class ReferenceInfo:
    """The references a record was measured against."""

    spp: int
    floor: float | None
    version: str


@dataclass(frozen=True)
class Spectrum:
    """A radially averaged power spectrum: ``power[i]`` at ``freq[i]`` cycles per pixel."""

    freq: list[float]
    power: list[float]


@dataclass(frozen=True)
class Record:
    """Everything measured for one cell (see the module docstring for each field's layout)."""

    cell: Cell
    dimensions: int
    t: list[int]
    raw: MetricPairs
    den: MetricPairs
    denoiser_params: dict[str, Any]
    timings: Timings
    reference: ReferenceInfo
    spectrum: dict[str, Spectrum]
    crop: str | None
    render_sampler: str | None = None
    tcorr: list[list[float]] | None = None
    coverage: list[list[float]] | None = None
    plugins: dict[str, dict[str, str]] | None = None
    looks: list[int] | None = None
    device: dict[str, str] | None = None

    @property
    def key(self) -> str:
        """The cell's key (:meth:`benchmarks.sweep.plan.Cell.key`)."""
        return self.cell.key()

    @property
    def has_pixels(self) -> bool:
        """Whether the cell's region held any pixel in some measured frame (a coherent region can
        be empty on a small or textured frame: its pairs are then all ``(0, 0)``, and the reports
        leave the record out)."""
        if self.coverage is None:
            return True
        return any(v > 0 for row in self.coverage for v in row)

    def to_json(self) -> dict[str, Any]:
        """The JSON object of one ``cells.jsonl`` line."""
        out = dataclasses.asdict(self)
        for late in (
            "render_sampler",
            "tcorr",
            "coverage",
            "plugins",
            "looks",
            "device",
        ):  # files from before they were recorded stay
            if out[late] is None:  # byte-identical
                del out[late]
        out["key"] = self.key
        return out

    def rounded(self) -> Record:
        """This record with its measured values at :data:`DIGITS` significant digits and its
        timings at :data:`TIMING_DIGITS` (idempotent: a rounded record rounds to itself, and
        reads back from its JSON line equal)."""
        return dataclasses.replace(
            self,
            raw=_round(self.raw, DIGITS),
            den=_round(self.den, DIGITS),
            timings=Timings(**_round(dataclasses.asdict(self.timings), TIMING_DIGITS)),
            reference=dataclasses.replace(
                self.reference, floor=_round(self.reference.floor, DIGITS)
            ),
            spectrum={
                k: Spectrum(freq=_round(v.freq, DIGITS), power=_round(v.power, DIGITS))
                for k, v in self.spectrum.items()
            },
            tcorr=_round(self.tcorr, DIGITS),
            coverage=_round(self.coverage, DIGITS),
        )

    @classmethod
    def from_json(cls, data: object) -> Record:
        """The record of one parsed ``cells.jsonl`` line.

        Raises:
            FileFormatError: not an object with the record's fields.
        """
        try:
            if not isinstance(data, dict):
                raise TypeError(f"a JSON object, got {type(data).__name__}")
            return cls(
                cell=Cell(**data["cell"]),
                dimensions=int(data["dimensions"]),
                t=list(data["t"]),
                raw=dict(data["raw"]),
                den=dict(data["den"]),
                denoiser_params=dict(data["denoiser_params"]),
                timings=Timings(**data["timings"]),
                reference=ReferenceInfo(**data["reference"]),
                spectrum=_spectra(data["spectrum"]),
                crop=data["crop"],
                render_sampler=data.get("render_sampler"),
                tcorr=data.get("tcorr"),
                coverage=data.get("coverage"),
                plugins=data.get("plugins"),
                looks=data.get("looks"),
                device=data.get("device"),
            )
        except (KeyError, TypeError, ValueError) as err:
            what = f"missing field {err}" if isinstance(err, KeyError) else str(err)
            raise FileFormatError(f"expected a benchmark record, got {what}") from None


def bare_key(cell: Cell) -> str:
    """The key of ``cell`` whatever its seed sets: the same at every look of an adaptive run."""
    return dataclasses.replace(cell, seed_sets=0).key()


def final_records(records: Iterable[Record]) -> list[Record]:
    """``records`` without those an adaptive run superseded: a record with ``looks`` is dropped
    when another record of the same cell (its key but for ``seed_sets``) with ``looks`` has more
    seed sets (``bnerr bench --until-resolved`` keeps every look's records, so that a resumed
    run replays the same verdicts; the reports show the last look). Order kept."""
    records = list(records)
    most: dict[str, int] = {}
    for r in records:
        if r.looks:
            key = bare_key(r.cell)
            most[key] = max(most.get(key, 0), r.cell.seed_sets)
    return [r for r in records if not r.looks or r.cell.seed_sets == most[bare_key(r.cell)]]


def earlier_look(record: Record, seed_sets: int) -> Record:
    """The record of ``record``'s cell at an earlier look of ``seed_sets``: its first
    ``seed_sets`` rows of every per-seed-set field. The runners keep seed set g the same render
    at every look and join a look's new seed sets after the previous look's rows
    (:mod:`benchmarks.sweep.reuse`), so these rows are that look's record's, and its verdict
    the same; the spectra, means over the seed sets, stay the later look's (no verdict reads
    them), so the record is for replaying verdicts, never for writing.

    Raises:
        ValueRangeError: ``seed_sets`` not below the record's, or not one of its looks.
    """
    if not record.looks or seed_sets not in record.looks or seed_sets >= record.cell.seed_sets:
        raise ValueRangeError(
            f"earlier_look {record.key}: expected one of its earlier looks {record.looks}, got "
            f"{seed_sets}"
        )

    def head(rows: list | None) -> list | None:
        return None if rows is None else rows[:seed_sets]

    return dataclasses.replace(
        record,
        cell=dataclasses.replace(record.cell, seed_sets=seed_sets),
        raw={m: rows[:seed_sets] for m, rows in record.raw.items()},
        den={m: rows[:seed_sets] for m, rows in record.den.items()},
        timings=Timings(
            **{k: v[:seed_sets] for k, v in dataclasses.asdict(record.timings).items()}
        ),
        tcorr=head(record.tcorr),
        coverage=head(record.coverage),
    )


def _round(value: Any, digits: int) -> Any:
    """``value`` with every float at ``digits`` significant digits but whole numbers (the pixel
    counts that weigh a metric's frames stay exact at any size); nested lists and dicts kept,
    ints, None and strings as they are."""
    if isinstance(value, float):
        return value if value.is_integer() else float(f"{value:.{digits}g}")
    if isinstance(value, list):
        return [_round(v, digits) for v in value]
    if isinstance(value, dict):
        return {k: _round(v, digits) for k, v in value.items()}
    return value


def _spectra(data: dict) -> dict[str, Spectrum]:
    """The spectra of a record: ``raw`` and ``den`` always, ``coherent`` when measured."""
    kinds = ("raw", "den") + (("coherent",) if "coherent" in data else ())
    return {kind: Spectrum(**data[kind]) for kind in kinds}


def _parse_line(path: Path, number: int, line: bytes) -> Record:
    try:
        text = line.decode("utf-8")
    except UnicodeDecodeError as err:
        raise FileFormatError(
            f"{path}: expected UTF-8 JSON records, got bad bytes on line {number} "
            f"(at byte {err.start})"
        ) from None
    try:
        return Record.from_json(json.loads(text))
    except json.JSONDecodeError as err:
        raise FileFormatError(
            f"{path}: expected one JSON record per line, got bad line {number}: {err}"
        ) from None
    except FileFormatError as err:
        raise FileFormatError(f"{path}: line {number}: {err}") from None


def _unpack(path: Path) -> bytes:
    """The lines of a results file: read, and decompressed when it is an archive.

    Raises:
        FileFormatError: unreadable, or not the archive its name says.
    """
    try:
        data = path.read_bytes()
        if path.name == RESULTS_ARCHIVE:
            return lzma.decompress(data, format=lzma.FORMAT_XZ)
        return gzip.decompress(data) if path.name == LEGACY_ARCHIVE else data
    except (OSError, EOFError, gzip.BadGzipFile, lzma.LZMAError) as err:
        raise FileFormatError(f"{path}: expected a readable results file, got {err}") from None


def _read_results(out_dir: str | Path) -> tuple[Path, bytes] | None:
    """The path and bytes of the folder's results (the plain file, else the xz archive, else the
    gzip one, decompressed), or None when it has none."""
    for name in (RESULTS_FILE, *ARCHIVES):
        path = Path(out_dir) / name
        if path.exists():
            return path, _unpack(path)
    return None


def compress_records(out_dir: str | Path) -> Path | None:
    """Replace ``<out_dir>/cells.jsonl`` (or an older ``cells.jsonl.gz``) by ``cells.jsonl.xz``,
    the same bytes compressed reproducibly (xz preset 9, no time stamp), atomically; return its
    path, or None when there is nothing to compress."""
    _restore_plain(out_dir, LEGACY_ARCHIVE)
    path = Path(out_dir) / RESULTS_FILE
    if not path.is_file():
        return None
    archive = Path(out_dir) / RESULTS_ARCHIVE
    with atomic_write(archive) as tmp:
        packed = lzma.compress(path.read_bytes(), format=lzma.FORMAT_XZ, preset=9)
        Path(tmp).write_bytes(packed)
    path.unlink()
    return archive


def compact_records(out_dir: str | Path) -> Path | None:
    """Round the folder's records (:meth:`Record.rounded`), keep each adaptive cell's last look
    only (:func:`final_records`; ``--until-resolved --resume`` replays the earlier looks from it,
    :func:`earlier_look`), in their order, and compress them (:func:`compress_records`); return
    the archive, or None without records.

    Raises:
        FileFormatError: the folder's results file is not valid.
    """
    records = load_records(out_dir)
    if not records:
        return None
    write_records(out_dir, [r.rounded() for r in final_records(records)])
    return compress_records(out_dir)


def _restore_plain(out_dir: str | Path, *names: str) -> None:
    """Turn a compressed results file (any of ``names``; default both) back into
    ``cells.jsonl`` (before appending to it)."""
    plain = Path(out_dir) / RESULTS_FILE
    for name in names or ARCHIVES:
        archive = Path(out_dir) / name
        if archive.exists() and not plain.exists():
            data = _unpack(archive)
            with atomic_write(plain) as tmp:
                Path(tmp).write_bytes(data)
            archive.unlink()


def load_records(out_dir: str | Path, *, torn_tail: bool = False) -> list[Record]:
    """The records in ``<out_dir>/cells.jsonl`` (empty if there is none), in file order.

    Args:
        torn_tail: drop, with a warning, a last line that has no newline and is not a record
            (what an append cut short leaves: :func:`append_records`); the resuming runner
            measures its cell again. False: such a line raises like any other bad line.

    Raises:
        FileFormatError: the file cannot be read, or a line is not UTF-8, not JSON (a truncated
            line among them, unless ``torn_tail``) or not a record; the message names the file
            and the line.
    """
    found = _read_results(out_dir)
    if found is None:
        return []
    path, data = found
    lines = data.split(b"\n")
    records = []
    with collector_paused():
        for number, line in enumerate(lines, start=1):
            if not line.strip():
                continue
            try:
                records.append(_parse_line(path, number, line))
            except FileFormatError:
                if not (torn_tail and number == len(lines)):  # the last piece: no newline after
                    raise
                warnings.warn(
                    f"{path}: line {number} was cut short (an interrupted append); its cell is "
                    "measured again",
                    stacklevel=2,
                )
    return records


@contextlib.contextmanager
def collector_paused() -> Iterator[None]:
    """Python's cycle collector off while a results file is parsed or its records summarized,
    as it was before after.

    A suite's records are millions of floats in lists and dicts; each collection the parser's
    allocations trigger walks every object made so far, which is three quarters of a large
    file's reading (the quality suite's 85 MB: 9.8 s with it, 2.8 s without) and 40 % of its
    summary (:func:`benchmarks.reports.table.summarize`). Records and rows hold no cycles, so
    nothing the collector would have freed is kept."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _lines(records: Iterable[Record]) -> bytes:
    text = "".join(json.dumps(r.to_json(), sort_keys=True) + "\n" for r in records)
    return text.encode("utf-8")


def write_records(out_dir: str | Path, records: Iterable[Record]) -> None:
    """Replace ``<out_dir>/cells.jsonl`` atomically with ``records``, one sorted-key JSON line
    each."""
    data = _lines(records)
    with atomic_write(Path(out_dir) / RESULTS_FILE) as tmp:
        Path(tmp).write_bytes(data)
    for name in ARCHIVES:  # superseded
        (Path(out_dir) / name).unlink(missing_ok=True)


def append_records(out_dir: str | Path, records: Iterable[Record]) -> None:
    """Append ``records`` to ``<out_dir>/cells.jsonl`` (which must end with a whole line, as
    :func:`write_records` leaves it), in one ``write`` and synced to disk before returning.

    A crash during the write can leave only a last line without its newline (a torn tail, which
    ``load_records(..., torn_tail=True)`` drops), never a whole line lost or written twice. A
    write the file system refuses (a full disk) is undone: the file is cut back to its length
    before the call.

    Raises:
        OutputPathError: the file system refused the write (no room, read-only); nothing of
            ``records`` remains in the file.
        FileFormatError: the file does not end with a whole line.
    """
    data = _lines(records)
    if not data:
        return
    _restore_plain(out_dir)
    path = Path(out_dir) / RESULTS_FILE
    fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        size = os.fstat(fd).st_size
        if size and os.pread(fd, 1, size - 1) != b"\n":
            raise FileFormatError(
                f"{path}: expected a results file ending with a whole line before appending, "
                "got a last line without its newline (rewrite it with write_records first)"
            )
        _write_all(fd, data, size, path)
    finally:
        os.close(fd)


def _write_all(fd: int, data: bytes, size: int, path: Path) -> None:
    """Write and sync ``data`` at the end of ``fd`` (``size`` bytes long before it); if the file
    system refuses (a full disk), cut the file back to ``size`` and raise
    :class:`~bnerr.outputs.OutputPathError`: what was there stays whole, nothing half-written."""
    try:
        view = memoryview(data)
        while view:  # a regular file takes the whole write at once, or part of it on a full disk
            view = view[os.write(fd, view) :]
        os.fsync(fd)
    except OSError as err:
        with contextlib.suppress(OSError):
            os.ftruncate(fd, size)
        raise OutputPathError(
            f"{path}: expected room to append {len(data)} bytes of results, got "
            f"{err.strerror or err}; the cells before them are kept whole (rerun with --resume "
            "once there is room)"
        ) from err


def check_no_results(out_dir: str | Path, *, resumable: bool = True) -> None:
    """Raise :class:`ResultsExistError` if ``<out_dir>/cells.jsonl`` holds any line (finished
    cells that a fresh run would discard); the file is not parsed. ``resumable``: the command
    has ``--resume`` (``bnerr bench``), which the message then offers; ``bnerr eval`` has not."""
    found = _read_results(out_dir)
    if found is None:
        return
    path, data = found
    count = sum(1 for line in data.split(b"\n") if line.strip())
    if count:
        raise ResultsExistError(
            f"{path}: expected no finished cells in the output folder of a fresh run, got "
            + (
                f"{count}; pass --resume to keep them and measure only the missing cells, or "
                "--overwrite to discard them"
                if resumable
                else f"{count}; pass --overwrite to discard them, or choose another --out"
            )
        )

"""Tests of benchmarks.sweep.records: the typed record's JSON round trip, the committed results
files, and typed errors (naming file and line) for garbled, truncated or foreign lines."""

import dataclasses
import gc
import gzip
import json
import lzma
import re

import pytest

from benchmarks.sweep.plan import Cell
from benchmarks.sweep.records import (
    DIGITS,
    LEGACY_ARCHIVE,
    RESULTS_ARCHIVE,
    RESULTS_FILE,
    Record,
    ReferenceInfo,
    ResultsExistError,
    Spectrum,
    Timings,
    append_records,
    check_no_results,
    collector_paused,
    compact_records,
    compress_records,
    earlier_look,
    final_records,
    load_records,
    write_records,
)
from bnerr.errors import BnerrError, FileFormatError, ValueRangeError
from tests._paths import RESULTS, ROOT
from tests._records import metric_pairs, small_record


def _record(strategy: str = "white", crop: str | None = None) -> Record:
    cell = Cell(
        scene="direct", strategy=strategy, spp=1, denoiser="gaussian", motion=1, depth=None,
        region="all", sampler="owen_sobol", frames=2, warmup=1, width=16, height=12, seed_sets=1,
        reference_spp=16,
    )  # fmt: skip
    return Record(
        cell=cell,
        dimensions=4,
        t=[1, 2],
        raw={"mse": [[[0.5, 576.0], [0.25, 576.0]]]},
        den={"mse": [[[0.125, 576.0], [0.0625, 576.0]]]},
        denoiser_params={"sigma": 1.5},
        timings=Timings(render_ms=[[1.0, 2.0]], perm_ms=[[0.1, 0.2]], denoise_ms=[[0.3, 0.4]]),
        reference=ReferenceInfo(spp=16, floor=None, version="0-abc"),
        spectrum={"raw": Spectrum([0.0, 0.5], [1.0, 2.0]), "den": Spectrum([], [])},
        crop=crop,
    )


def test_a_record_round_trips_through_json_with_its_key():
    rec = _record(crop="crops/x.npz")
    data = json.loads(json.dumps(rec.to_json(), sort_keys=True))
    assert data["key"] == rec.cell.key() == rec.key
    assert data["timings"]["render_ms"] == [[1.0, 2.0]] and data["spectrum"]["den"]["freq"] == []
    assert Record.from_json(data) == rec


def test_the_frame_to_frame_correlation_round_trips_and_is_absent_when_not_recorded():
    import dataclasses

    rec = dataclasses.replace(_record(), tcorr=[[0.25]])
    data = json.loads(json.dumps(rec.to_json(), sort_keys=True))
    assert data["tcorr"] == [[0.25]] and Record.from_json(data) == rec
    plain = _record().to_json()
    assert "tcorr" not in plain and Record.from_json(plain).tcorr is None


def test_the_coherent_spectrum_round_trips_when_measured():
    import dataclasses

    spectra = {**_record().spectrum, "coherent": Spectrum([0.0, 0.5], [3.0, 4.0])}
    rec = dataclasses.replace(_record(), spectrum=spectra)
    data = json.loads(json.dumps(rec.to_json(), sort_keys=True))
    assert data["spectrum"]["coherent"]["power"] == [3.0, 4.0] and Record.from_json(data) == rec
    assert "coherent" not in Record.from_json(_record().to_json()).spectrum


def test_write_and_load_keep_order_and_values(tmp_path):
    records = [_record("white"), _record("temporal")]
    write_records(tmp_path, records)
    assert load_records(tmp_path) == records
    assert load_records(tmp_path / "nowhere") == []
    assert not list(tmp_path.glob(".*.tmp*"))


#: Above this many records a committed file's rewrite is compared on every STRIDE-th record,
#: parsed from its own line (each line is one record's ``json.dumps``, so the file is the
#: concatenation of its lines): the quality suite's 6,048 records take 9 CPU-s to parse and 2 to
#: serialize again. Every record of every committed file is parsed by the byte-for-byte
#: regeneration of its tables (tests/benchmarks/reports/test_table_committed.py).
_FULL_REWRITE_UP_TO, _STRIDE = 2000, 7


def _committed_lines(folder) -> bytes:
    """The committed results' lines: the archive's content, not its compression
    (compress_records is reproducible bit for bit:
    test_compressed_results_read_back_and_restore_before_an_append)."""
    plain, archive = folder / RESULTS_FILE, folder / RESULTS_ARCHIVE
    if plain.exists():
        return plain.read_bytes()
    if archive.exists():
        return lzma.decompress(archive.read_bytes())
    return gzip.decompress((folder / LEGACY_ARCHIVE).read_bytes())


@pytest.mark.parametrize("suite", ["quick", "quality", "stability", "gap"])
def test_the_committed_results_load_and_rewrite_byte_identical(tmp_path, suite):
    folder = RESULTS / suite
    if not any((folder / n).exists() for n in (RESULTS_FILE, RESULTS_ARCHIVE, LEGACY_ARCHIVE)):
        pytest.skip(f"no committed {suite} results")
    committed = _committed_lines(folder)
    lines = committed.splitlines(keepends=True)
    if len(lines) <= _FULL_REWRITE_UP_TO:
        records = load_records(folder)  # cells.jsonl, or the committed archive
        assert len(records) == len(lines) and all(isinstance(r, Record) for r in records)
        write_records(tmp_path, records)
        assert (tmp_path / RESULTS_FILE).read_bytes() == committed
    else:
        picked = sorted({*range(0, len(lines), _STRIDE), len(lines) - 1})
        records = [Record.from_json(json.loads(lines[i])) for i in picked]
        assert any(r.looks for r in records) == (b'"looks": ' in committed)
        write_records(tmp_path, records)
        assert (tmp_path / RESULTS_FILE).read_bytes() == b"".join(lines[i] for i in picked)
    write_records(tmp_path, [_record("white"), _record("temporal")])
    with pytest.raises(ResultsExistError, match=r"got 2; pass --resume .* or --overwrite") as err:
        check_no_results(tmp_path)
    assert isinstance(err.value, BnerrError) and isinstance(err.value, FileExistsError)


def test_compressed_results_read_back_and_restore_before_an_append(tmp_path):
    records = [_record("white"), _record("temporal"), _record("oracle")]
    write_records(tmp_path, records[:1])
    plain = (tmp_path / RESULTS_FILE).read_bytes()
    archive = compress_records(tmp_path)
    assert archive == tmp_path / RESULTS_ARCHIVE and not (tmp_path / RESULTS_FILE).exists()
    assert compress_records(tmp_path) is None  # nothing plain left to compress
    first = archive.read_bytes()
    assert load_records(tmp_path) == records[:1]
    with pytest.raises(ResultsExistError):
        check_no_results(tmp_path)
    append_records(tmp_path, records[1:])  # the plain file comes back, then grows
    assert not archive.exists() and (tmp_path / RESULTS_FILE).read_bytes().startswith(plain)
    assert load_records(tmp_path) == records
    write_records(tmp_path, records[:1])
    assert compress_records(tmp_path).read_bytes() == first  # reproducible: no time stamp
    write_records(tmp_path, records)
    assert not archive.exists()  # a rewritten plain file supersedes the compressed one


def test_an_older_gzip_archive_reads_and_turns_into_the_xz_one(tmp_path):
    records = [_record("white"), _record("temporal")]
    write_records(tmp_path, records)
    plain = (tmp_path / RESULTS_FILE).read_bytes()
    (tmp_path / LEGACY_ARCHIVE).write_bytes(gzip.compress(plain, mtime=0))
    (tmp_path / RESULTS_FILE).unlink()
    assert load_records(tmp_path) == records
    with pytest.raises(ResultsExistError):
        check_no_results(tmp_path)
    archive = compress_records(tmp_path)  # the next compression turns it into the xz archive
    assert archive == tmp_path / RESULTS_ARCHIVE and not (tmp_path / LEGACY_ARCHIVE).exists()
    assert lzma.decompress(archive.read_bytes()) == plain


def _noisy_record() -> Record:
    """A record whose values carry all 17 digits of a float, as an unrounded run leaves them."""
    rec = _record()
    third = 1.0 / 3.0
    return dataclasses.replace(
        rec,
        raw={"mse": [[[third, 576.0], [2 * third, 576.0]]]},
        den={"mse": [[[third / 7, 196608.0], [123456.789, 196608.0]]]},
        timings=Timings(render_ms=[[12.3456, 2.0]], perm_ms=[[0.1, 0.2]], denoise_ms=[[0.3, 0.4]]),
        reference=ReferenceInfo(spp=16, floor=third, version="0-abc"),
        spectrum={"raw": Spectrum([0.0, third], [1.0, 2 * third]), "den": Spectrum([], [])},
        tcorr=[[third]],
        coverage=[[third, 1.0]],
    )


def test_a_rounded_record_keeps_its_digits_reads_back_equal_and_rounds_to_itself():
    rec = _noisy_record().rounded()
    assert rec.raw["mse"][0][0] == [0.3333, 576.0] and rec.den["mse"][0][1][0] == 123500.0
    assert rec.den["mse"][0][1][1] == 196608.0  # a pixel count (256 x 256 x 3) stays exact
    assert rec.timings.render_ms == [[12.3, 2.0]]  # timings keep 3 digits
    assert rec.reference.floor == 0.3333 and rec.tcorr == [[0.3333]]
    assert rec.spectrum["raw"].freq == [0.0, 0.3333] and rec.coverage == [[0.3333, 1.0]]
    assert rec.rounded() == rec
    assert Record.from_json(json.loads(json.dumps(rec.to_json()))) == rec
    # within half a unit of the DIGITS-th significant digit: a relative 5e-4 at most
    assert abs(rec.den["mse"][0][0][0] - 1 / 21) <= 0.5 * 10 ** (1 - DIGITS) * (1 / 21)


def test_compacting_a_folder_rounds_its_records_in_their_order_and_compresses_them(tmp_path):
    assert compact_records(tmp_path) is None  # no records: nothing written
    records = [_noisy_record(), _record("temporal")]
    write_records(tmp_path, records)
    assert compact_records(tmp_path) == tmp_path / RESULTS_ARCHIVE
    assert load_records(tmp_path) == [r.rounded() for r in records]
    assert load_records(tmp_path)[1] == records[1]  # a record already at its digits is unchanged


def test_an_earlier_look_is_the_first_rows_of_a_later_one():
    rows = [[i, 1.0] for i in range(4)]
    rec = dataclasses.replace(
        small_record("ldbn", "gaussian", raw={"mse": metric_pairs(rows)}, den={}, frames=2,
                     seed_sets=4),
        looks=[2, 4],
        tcorr=[[0.1], [0.2], [0.3], [0.4]],
    )  # fmt: skip
    two = earlier_look(rec, 2)
    assert two.cell.seed_sets == 2 and two.key != rec.key and two.looks == [2, 4]
    assert two.raw["mse"] == rec.raw["mse"][:2] and two.tcorr == [[0.1], [0.2]]
    assert all(len(v) == 2 for v in dataclasses.asdict(two.timings).values())
    for bad in (4, 3, 8):  # itself, not one of its looks, a later one
        with pytest.raises(ValueRangeError, match=r"expected one of its earlier looks \[2, 4\]"):
            earlier_look(rec, bad)


def test_compacting_keeps_each_adaptive_cells_last_look_only(tmp_path):
    def rec(seed_sets, looks):
        pairs = metric_pairs([[1.0, 1.0]] * seed_sets)
        r = small_record("ldbn", "gaussian", raw={}, den={"mse": pairs}, frames=2,
                         seed_sets=seed_sets)  # fmt: skip
        return dataclasses.replace(r, looks=looks)

    records = [rec(2, [2, 4]), _record("white"), rec(4, [2, 4])]
    write_records(tmp_path, records)
    compact_records(tmp_path)
    assert load_records(tmp_path) == [records[1], records[2]]


def test_a_broken_compressed_file_is_a_typed_error(tmp_path):
    (tmp_path / RESULTS_ARCHIVE).write_bytes(b"not xz")
    with pytest.raises(FileFormatError, match="cells.jsonl.xz"):
        load_records(tmp_path)


def test_final_records_keep_an_adaptive_cells_last_look_and_every_fixed_record():
    def rec(strategy, seed_sets, looks):
        pairs = metric_pairs([[1.0, 1.0]] * seed_sets)
        r = small_record(strategy, "gaussian", raw={}, den={"mse": pairs}, frames=2,
                         seed_sets=seed_sets)  # fmt: skip
        return dataclasses.replace(r, looks=looks)

    first, last = rec("temporal", 2, [2, 4]), rec("temporal", 4, [2, 4])
    fixed = [rec("white", 2, None), rec("white", 4, None)]  # two fixed runs: both kept
    assert final_records([first, *fixed, last]) == [*fixed, last]
    assert Record.from_json(json.loads(json.dumps(last.to_json()))).looks == [2, 4]
    assert "looks" not in fixed[0].to_json()  # files without a design stay byte-identical


def test_the_device_round_trips_and_is_absent_on_the_cpu():
    assert "device" not in _record().to_json()  # CPU records stay byte-identical
    where = {"device": "cuda:0", "name": "NVIDIA H200", "torch": "2.11.0", "cuda": "12.8"}
    rec = dataclasses.replace(_record(), device=where)
    data = json.loads(json.dumps(rec.to_json(), sort_keys=True))
    assert data["device"] == where and Record.from_json(data) == rec


@pytest.mark.parametrize("enabled", [True, False])
def test_the_collector_is_paused_only_while_records_are_read(tmp_path, enabled):
    write_records(tmp_path, [_record()])
    (tmp_path / RESULTS_FILE).write_bytes((tmp_path / RESULTS_FILE).read_bytes() + b"{")
    was = gc.isenabled()
    (gc.enable if enabled else gc.disable)()
    try:
        with collector_paused():
            assert not gc.isenabled()
        assert gc.isenabled() == enabled
        with pytest.raises(FileFormatError):  # a bad line: raised, and the collector restored
            load_records(tmp_path)
        assert gc.isenabled() == enabled
    finally:
        (gc.enable if was else gc.disable)()


def test_the_docs_and_the_help_state_the_precision_records_keep(capsys):
    """Issue 54: cells.jsonl's precision read 4 significant digits in USAGE, 5 in INTERFACES and
    6 in ``bench --help``; each now states :data:`DIGITS` (and :data:`TIMING_DIGITS`)."""
    from benchmarks.cli import build_parser
    from benchmarks.sweep.records import DIGITS, TIMING_DIGITS

    usage = (ROOT / "docs/USAGE.md").read_text()
    interfaces = " ".join((ROOT / "docs/INTERFACES.md").read_text().split())
    assert f"({DIGITS} significant digits, whole numbers" in " ".join(usage.split())
    assert f"keeps {DIGITS} significant digits of each measured value" in interfaces
    assert f"and {TIMING_DIGITS} of each timing" in interfaces
    with pytest.raises(SystemExit):
        build_parser("bench").parse_args(["bench", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"({DIGITS} significant digits, timings {TIMING_DIGITS})" in text
    found = {int(n) for n in re.findall(r"(\d) significant digits", usage + interfaces + text)}
    assert found == {DIGITS}

"""Seed sets kept between the looks of an adaptive run: a look renders only its new seed sets.

``bnerr bench --until-resolved`` (:mod:`benchmarks.sweep.adaptive`) looks at a cell after
``n_1 < n_2 < ... < n_K`` seed sets (:func:`bnerr.metrics.sequential.looks`, fixed before the
first seed set: for example 4, 8, 16, 32). Seed set g is the same render at every look (the
strategy is seeded by g alone), so the record of look k is the record of look k - 1 with seed sets
``n_{k-1} .. n_k - 1`` appended: :func:`with_reuse` marks a run whose every cell has its record at
the previous look (``Run.reuse``, that look's seed-set count; the runners then measure only
``range(run.reuse, run.seed_sets)``), and :func:`extend` joins the kept record and the new seed
sets' into the look's record. A cell that goes from 4 to the cap of 32 costs 32 seed sets, not
4 + 8 + 16 + 32 = 60, and each look still holds exactly ``n_k`` seed sets, the sizes the
boundary was computed for.

What the joined record holds: the per-seed-set arrays (``raw``, ``den``, ``timings``, ``tcorr``,
``coverage``, ``[S][F]``) are the kept rows then the new ones, as one render of all ``n_k`` would
stack them; the spectra and the reference floor are means over every measured frame, joined as
the mean weighted by seed sets (equal to one render's up to the last bits of rounding:
deterministic, but not bit-identical to measuring the ``n_k`` seed sets in one run); the crops
are seed set 0's, the kept record's. Only records measured with the same code version are kept
(a changed renderer renders the seed sets again); the plug-ins are checked for every resumed
record already (:func:`benchmarks.sweep.plugins.check_resume`).

Not for: planning the looks (:mod:`benchmarks.sweep.adaptive`) or measuring
(:mod:`benchmarks.sweep.measure`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

from benchmarks.sweep.plan import Cell, Run
from benchmarks.sweep.records import MetricPairs, Record, ReferenceInfo, Spectrum, Timings
from bnerr.errors import ValueRangeError

__all__ = ["earlier_look", "extend", "with_reuse"]


def earlier_look(run: Run) -> int | None:
    """The seed-set count of the look before ``run``'s in its design, or None (no design, or
    the first look)."""
    before = [n for n in run.looks if n < run.seed_sets]
    return before[-1] if before and run.seed_sets in run.looks else None


def _at(cell: Cell, seed_sets: int) -> str:
    """The key of ``cell`` at another look."""
    return dataclasses.replace(cell, seed_sets=seed_sets).key()


def with_reuse(run: Run, records: Mapping[str, Record], version: str) -> Run:
    """``run`` with ``reuse`` set to its previous look when every one of its cells has a record
    there measured with code ``version`` (those seed sets are then not measured again), else
    ``run`` as it is."""
    earlier = earlier_look(run)
    if earlier is None:
        return run
    kept = [records.get(_at(cell, earlier)) for cell in run.cells()]
    if all(r is not None and r.reference.version == version for r in kept):
        return dataclasses.replace(run, reuse=earlier)
    return run


def _rows(kept: list | None, new: list | None) -> list | None:
    return None if kept is None or new is None else [*kept, *new]


def _pairs(kept: MetricPairs, new: MetricPairs) -> MetricPairs:
    return {m: [*kept[m], *new[m]] for m in new}


def _mean(kept: float, new: float, n_kept: int, n_new: int) -> float:
    return (kept * n_kept + new * n_new) / (n_kept + n_new)


def _spectrum(kept: Spectrum | None, new: Spectrum, n_kept: int, n_new: int) -> Spectrum:
    if kept is None or kept.freq != new.freq:
        return new
    power = [_mean(a, b, n_kept, n_new) for a, b in zip(kept.power, new.power, strict=True)]
    return Spectrum(freq=list(new.freq), power=power)


def _floor(kept: ReferenceInfo, new: ReferenceInfo, n_kept: int, n_new: int) -> float | None:
    if kept.floor is None or new.floor is None:
        return new.floor
    return _mean(kept.floor, new.floor, n_kept, n_new)


def _join(kept: Record, new: Record, n_kept: int) -> Record:
    n_new = len(next(iter(new.raw.values()), []))
    spectra = {
        kind: _spectrum(kept.spectrum.get(kind), s, n_kept, n_new)
        for kind, s in new.spectrum.items()
    }
    timings = Timings(
        **{
            f.name: [*getattr(kept.timings, f.name), *getattr(new.timings, f.name)]
            for f in dataclasses.fields(Timings)
        }
    )
    return dataclasses.replace(
        new,
        raw=_pairs(kept.raw, new.raw),
        den=_pairs(kept.den, new.den),
        timings=timings,
        reference=dataclasses.replace(
            new.reference, floor=_floor(kept.reference, new.reference, n_kept, n_new)
        ),
        spectrum=spectra,
        crop=kept.crop,
        tcorr=_rows(kept.tcorr, new.tcorr),
        coverage=_rows(kept.coverage, new.coverage),
    )


def extend(run: Run, new: Sequence[Record], records: Mapping[str, Record]) -> list[Record]:
    """The records of ``run``'s look: each cell's record at the previous look (``run.reuse``
    seed sets, from ``records``) joined with its new seed sets' (``new``, seed sets
    ``run.reuse .. run.seed_sets - 1``, one per cell of ``run`` in its order).

    Raises:
        ValueRangeError: a kept record missing or not of ``run.reuse`` seed sets.
    """
    if not run.reuse:
        return list(new)
    out = []
    for record in new:
        kept = records.get(_at(record.cell, run.reuse))
        if kept is None or any(len(rows) != run.reuse for rows in kept.raw.values()):
            raise ValueRangeError(
                f"reuse {run.label}: expected the record of {record.cell.denoiser}/"
                f"{record.cell.region} at {run.reuse} seed sets, got "
                f"{'none' if kept is None else [len(r) for r in kept.raw.values()]}"
            )
        out.append(_join(kept, record, run.reuse))
    return out

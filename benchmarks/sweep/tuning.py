"""Tuned denoiser parameters: fair (on white noise) and own (on the strategy's noise).

- **Fair denoisers** (:func:`tune_denoisers`): each filter's parameters are tuned once per scene,
  condition and spp on white-noise frames (:mod:`denoisers.tuning`) and used unchanged for every
  strategy: the conservative column.
- **Own tuning** (``NAME:own``, e.g. ``gaussian:own``): the same filter and grid tuned on the
  run's strategy's own frames, as a team that adopts the strategy would re-tune; the tuning seed
  set (:data:`TUNING_SEED_SET`) is held out of the measured ones, so tuning cannot fit the
  measured noise. Both columns sit in one table under their names.

The parameters live in a :class:`TuningStore` (:class:`denoisers.tuning.ParamStore`, saved as
``<out>/tuned_params.json``), keyed by :func:`tuning_key` and spp.

Not for: the grid search itself (:func:`denoisers.tuning.tune`, through ``Parts.tune_denoiser``).
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path
from typing import Any, Protocol

from benchmarks.sweep.measure import References, scene_for, t_reference
from benchmarks.sweep.parts import BoundRender, Denoiser, Parts
from benchmarks.sweep.plan import Run
from bnerr.strategies import baseline, play

__all__ = [
    "OWN_SUFFIX",
    "TUNING_SEED_SET",
    "TuningStore",
    "store_key",
    "make_denoisers",
    "missing_tuning",
    "split_own",
    "store_tuned",
    "stored_params",
    "tune_denoisers",
    "tune_missing",
    "tuned_params",
    "tuning_key",
    "tuning_source",
]

#: The seed set of the white frames the denoisers are tuned on: no measured run uses it.
TUNING_SEED_SET = 1_000_003


class TuningStore(Protocol):
    """The tuned parameters as the sweep uses them (:class:`denoisers.tuning.ParamStore`, or a
    stand-in): name -> key -> spp -> parameters."""

    entries: dict

    def put(self, result: Any, scene: str, spp: int) -> None: ...

    def params(self, denoiser: str, scene: str, spp: int) -> dict: ...

    def save(self, path: str | Path) -> None: ...


#: A denoiser name ending in this (``gaussian:own``) is tuned on the run's strategy's own frames.
OWN_SUFFIX = ":own"


def split_own(name: str) -> tuple[str, bool]:
    """``"gaussian:own"`` -> ``("gaussian", True)``; ``"gaussian"`` -> ``("gaussian", False)``."""
    if name.endswith(OWN_SUFFIX):
        return name[: -len(OWN_SUFFIX)], True
    return name, False


def tuning_key(run: Run) -> str:
    """What the tuned parameters depend on besides spp: scene, condition, sampler and resolution."""
    depth = "" if run.depth is None else f"/d{run.depth}"
    return f"{run.scene}/m{run.motion}{depth}/{run.sampler}/{run.width}x{run.height}"


def tuning_source(run: Run, name: str) -> str:
    """The strategy whose frames ``name`` is tuned on: the baseline (white,
    :func:`bnerr.strategies.baseline`), or the run's own for ``NAME:own``."""
    return run.strategy if split_own(name)[1] else baseline()


def store_key(run: Run, name: str) -> str:
    """The store's key of ``name``'s parameters for ``run``: :func:`tuning_key`, plus the
    strategy for ``NAME:own`` (stored under its own name, ``gaussian:own``)."""
    key = tuning_key(run)
    return f"{key}/{run.strategy}" if split_own(name)[1] else key


def stored_params(store: TuningStore, name: str, key: str, spp: int) -> dict | None:
    """The stored parameters, or None for a denoiser without any (nothing to tune)."""
    if str(spp) in store.entries.get(name, {}).get(key, {}):
        return store.params(name, key, spp)
    return None


def missing_tuning(run: Run, store: TuningStore) -> dict[str, list[str]]:
    """The run's denoisers with no parameters in ``store`` for its scene, condition and spp, by
    :func:`tuning_source` (those without a grid among them: they are never stored)."""
    missing: dict[str, list[str]] = {}
    for name in run.denoisers:
        if stored_params(store, name, store_key(run, name), run.spp) is None:
            missing.setdefault(tuning_source(run, name), []).append(name)
    return missing


def tune_missing(
    run: Run, parts: Parts, references: References, names: list[str], source: str
) -> dict[str, Any]:
    """Tune ``names`` for ``run``'s scene, condition and spp on the frames of strategy
    ``source``: name -> TuneResult, or None for a denoiser with nothing to tune.

    The frames are ``min(frames, 4)`` measured frames (a stateful ``source`` renders its warmup
    frames first) from a seed set no measured run uses (:data:`TUNING_SEED_SET`: held out, so
    that tuning cannot fit the measured noise), against the same references. Nothing is rendered
    when ``names`` is empty. ``NAME`` and ``NAME:own`` among ``names`` share one search (the
    same frames give the same result).
    """
    if not names:
        return {}
    scene = scene_for(run, parts)
    strategy = parts.make_strategy(
        source, scene, run.height, run.width, TUNING_SEED_SET, run.sampler, run.spp
    )
    frames, refs = [], []
    shown = range(run.warmup, run.warmup + min(run.frames, 4))
    render_at = functools.partial(BoundRender, parts, scene, run.spp)
    for t, frame in play(strategy, render_at, shown, max(run.motion, 1)):
        if t >= run.warmup:
            frames.append(frame)
            refs.append(references.get(run, scene, t_reference(run, t)).color)
    # ``NAME`` and ``NAME:own`` on the same frames (the white run) are one grid search
    tuned: dict[str, Any] = {}
    for base in dict.fromkeys(split_own(name)[0] for name in names):
        tuned[base] = parts.tune_denoiser(base, frames, refs)
    return {name: tuned[split_own(name)[0]] for name in names}


def store_tuned(run: Run, store: TuningStore, results: dict[str, Any], source: str) -> None:
    """Put the results of :func:`tune_missing` on ``source``'s frames (those not None) in
    ``store`` under ``run``'s key and spp; ``NAME:own`` under its own name, its key naming
    ``source`` (the strategy it was tuned on, whichever run asked)."""
    for name, result in results.items():
        if result is None:
            continue
        key = tuning_key(run)
        if split_own(name)[1]:
            key = f"{key}/{source}"
            if dataclasses.is_dataclass(result) and not isinstance(result, type):
                result = dataclasses.replace(result, denoiser=name)
        store.put(result, key, run.spp)


def tuned_params(run: Run, store: TuningStore) -> dict[str, dict | None]:
    """Name -> the stored parameters of each of the run's denoisers (None: nothing to tune)."""
    return {
        name: stored_params(store, name, store_key(run, name), run.spp) for name in run.denoisers
    }


def make_denoisers(parts: Parts, params: dict[str, dict | None]) -> dict[str, Denoiser]:
    """Name -> denoiser built with its parameters (:func:`tuned_params`); ``NAME:own`` is
    ``NAME`` with its own parameters."""
    return {name: parts.make_denoiser(split_own(name)[0], p) for name, p in params.items()}


def tune_denoisers(
    run: Run, parts: Parts, references: References, store: TuningStore
) -> dict[str, Denoiser]:
    """The run's denoisers with their tuned parameters for its scene, condition and spp.

    Parameters missing from ``store`` are tuned now (:func:`tune_missing`, per
    :func:`tuning_source`) and put in the store; the fair ones (tuned on white noise) are then
    used unchanged for every strategy, the ``NAME:own`` ones for the strategy they were tuned on.
    """
    for source, names in missing_tuning(run, store).items():
        store_tuned(run, store, tune_missing(run, parts, references, names, source), source)
    return make_denoisers(parts, tuned_params(run, store))

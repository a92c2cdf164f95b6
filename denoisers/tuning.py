"""Fair filter parameters: tuned per scene and spp on white noise, then frozen for every strategy.

A filter tuned on the renders of one strategy would favour that strategy. So each filter's
parameters are chosen once per (scene, spp) by a small grid search that minimizes the MSE to the
reference on **white-noise** renders, stored in a JSON file, and the benchmark then uses the stored
values unchanged for white, blue-noise and every other strategy. The grid is small on purpose: it
is there to put each filter near its best setting, not to squeeze the last percent.

File format (JSON, written atomically)::

    {"format": "bnerr-tuned-params-v1",
     "entries": {"<denoiser>": {"<scene>": {"<spp>": {
         "params": {...}, "mse": float, "noisy_mse": float, "frames": int,
         "sampler": "white"}}}}}

Only the denoisers with a tuning grid have parameters to tune (their class's ``grid``, collected
in :data:`GRIDS`); the others (``unet``, ``oidn``) have none and are looked up with their
defaults.

Stateful denoisers (``taa``, ``svgf``: ``stateful = True``) are tuned on a sequence: the frames in
their order, each candidate reset and fed all of them, its MSE taken over the frames after the
first :data:`STATEFUL_SKIP` (while its history fills up its output is not what it will be).

This module renders nothing (denoisers do not import the renderer): the caller passes the noisy
frames and the reference.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import torch

from bnerr.errors import (
    DtypeError,
    FileFormatError,
    UnknownNameError,
    ValueRangeError,
    check_name,
    check_positive_int,
    check_range,
    check_shape,
)
from bnerr.frame import Frame
from bnerr.io import atomic_write
from bnerr.views import LiveMapping
from denoisers import DENOISERS, get_denoiser
from denoisers.base import Denoiser

__all__ = [
    "GRIDS",
    "PARAMS_FORMAT",
    "STATEFUL_SKIP",
    "ParamStore",
    "TuneResult",
    "grid_points",
    "tune",
    "tuned_denoiser",
]

#: Format tag of the stored-parameters file.
PARAMS_FORMAT = "bnerr-tuned-params-v1"


def _grids() -> dict[str, Mapping[str, Sequence]]:
    return {name: cls.grid for name, cls in DENOISERS.items() if cls.grid}


#: The search grid of each tunable denoiser, parameter -> candidate values: its class's ``grid``
#: (:class:`denoisers.base.Denoiser`), read from :data:`denoisers.DENOISERS` whenever asked.
GRIDS: Mapping[str, Mapping[str, Sequence]] = LiveMapping(_grids)

#: Frames a stateful denoiser is fed, by default, before the frames its MSE is measured on.
STATEFUL_SKIP = 2


def grid_points(grid: Mapping[str, Sequence]) -> list[dict]:
    """Every combination of a grid, in a fixed order (the product, keys sorted)."""
    keys = sorted(grid)
    return [dict(zip(keys, values)) for values in itertools.product(*(grid[k] for k in keys))]


@dataclass
class TuneResult:
    """The outcome of :func:`tune`.

    Attributes:
        denoiser: the filter's name.
        params: the grid point with the lowest MSE (the first one on a tie).
        mse: its MSE to the reference, averaged over the frames.
        noisy_mse: the MSE of the noisy frames themselves (the measured ones).
        frames: how many frames the MSEs average over.
        table: every grid point with its MSE, in grid order.
        skipped: leading frames denoised but not measured (a stateful denoiser's warm-up).
    """

    denoiser: str
    params: dict
    mse: float
    noisy_mse: float
    frames: int
    table: list[tuple[dict, float]] = field(default_factory=list)
    skipped: int = 0


def _mse(a: torch.Tensor, b: torch.Tensor) -> float:
    return float((a.double() - b.double()).square().mean())


def tune(
    name: str,
    frames: Sequence[Frame],
    references: Sequence[torch.Tensor],
    grid: Mapping[str, Sequence] | None = None,
    skip: int | None = None,
) -> TuneResult:
    """Grid-search filter ``name`` on white-noise ``frames`` against ``references``.

    Args:
        name: a tunable filter (a key of :data:`GRIDS`).
        frames: noisy renders of one scene at one spp, made with the white sampler. For a
            stateful denoiser, one sequence in frame order (same size, consecutive times): each
            candidate is reset and fed them all with indices ``t = 0, 1, ...``.
        references: the reference color ``[3, H, W]`` of each frame (the same tensor may repeat
            when the frames share a time ``t``).
        grid: overrides :data:`GRIDS`\\ ``[name]``.
        skip: leading frames left out of the MSE (a stateful denoiser still sees them); default
            0, and ``min(STATEFUL_SKIP, len(frames) - 1)`` for a stateful denoiser.

    Returns:
        The best parameters by mean MSE over the frames after ``skip``.

    Raises:
        UnknownNameError: ``name`` is not tunable.
        ValueRangeError: no frames, not one reference per frame, or ``skip`` leaves none.
        DtypeError: ``skip`` is not an int.
        ShapeError: a reference does not match its frame.
        SequenceError: (stateful) the frames are not all of one size.
    """
    check_name(name, list(GRIDS), "tunable denoiser")
    if len(frames) == 0 or len(frames) != len(references):
        raise ValueRangeError(
            f"tune: expected one reference per frame and at least one frame, "
            f"got {len(frames)} frames and {len(references)} references"
        )
    for i, (frame, ref) in enumerate(zip(frames, references)):
        check_shape(ref, f"3 {frame.height} {frame.width}", f"tune: references[{i}]")
    stateful = DENOISERS[name].stateful
    if skip is None:
        skip = min(STATEFUL_SKIP, len(frames) - 1) if stateful else 0
    if isinstance(skip, bool) or not isinstance(skip, int):
        raise DtypeError(f"tune: skip: expected an int, got {type(skip).__name__} {skip!r}")
    check_range(skip, "tune: skip", 0, len(frames) - 1)
    measured = list(zip(frames[skip:], references[skip:]))
    noisy = sum(_mse(f.color, r) for f, r in measured) / len(measured)
    table = []
    for params in grid_points(grid if grid is not None else GRIDS[name]):
        denoiser = get_denoiser(name, **params)
        table.append((params, _mean_mse(denoiser, frames, references, skip)))
    best, best_mse = min(table, key=lambda row: row[1])  # min keeps the first of equal values
    return TuneResult(name, best, best_mse, noisy, len(measured), table, skip)


def _mean_mse(
    denoiser: Denoiser,
    frames: Sequence[Frame],
    references: Sequence[torch.Tensor],
    skip: int,
) -> float:
    """Mean MSE of ``denoiser`` over ``frames[skip:]``; a stateful one is reset and fed all."""
    denoiser.reset()
    total = 0.0
    for t, (frame, ref) in enumerate(zip(frames, references)):
        if t < skip and not denoiser.stateful:
            continue
        out = denoiser(frame, t=t)
        if t >= skip:
            total += _mse(out, ref)
    return total / (len(frames) - skip)


def _atomic_write_text(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path) as tmp:
        tmp.write_text(text)


class ParamStore:
    """Tuned parameters by (denoiser, scene, spp), loaded from and saved to a JSON file."""

    def __init__(self, entries: dict | None = None) -> None:
        self.entries: dict[str, dict[str, dict[str, dict]]] = entries if entries is not None else {}

    def put(self, result: TuneResult, scene: str, spp: int, sampler: str = "white") -> None:
        """Store ``result`` as the parameters of ``result.denoiser`` on ``scene`` at ``spp``."""
        check_positive_int(spp, "ParamStore.put: spp")
        if not isinstance(scene, str) or not scene:
            raise DtypeError(f"ParamStore.put: scene: expected a non-empty str, got {scene!r}")
        self.entries.setdefault(result.denoiser, {}).setdefault(scene, {})[str(spp)] = {
            "params": dict(result.params),
            "mse": result.mse,
            "noisy_mse": result.noisy_mse,
            "frames": result.frames,
            "sampler": sampler,
        }

    def params(self, denoiser: str, scene: str, spp: int) -> dict:
        """The stored parameters of ``denoiser`` on ``scene`` at ``spp``.

        Raises:
            UnknownNameError: nothing stored for that triple (the message lists what is).
        """
        try:
            return dict(self.entries[denoiser][scene][str(spp)]["params"])
        except KeyError:
            have = sorted(
                f"{d}/{s}/{n}"
                for d, by_scene in self.entries.items()
                for s, by_spp in by_scene.items()
                for n in by_spp
            )
            raise UnknownNameError(
                f"tuned params: expected an entry for {denoiser}/{scene}/{spp} spp, got none "
                f"(stored: {', '.join(have) or 'nothing'})"
            ) from None

    def resolve(self, denoiser: str, scene: str, spp: int | None = None) -> tuple[str, int]:
        """The stored ``(scene key, spp)`` that ``scene`` and ``spp`` name for ``denoiser``.

        ``scene`` is a stored key (``"direct/m1/owen_sobol/128x128"``) or its first part, the
        scene's name (``"direct"``), which must then match exactly one key; ``spp`` may be None
        when that key holds one spp. Denoisers without a grid (``unet``, ``oidn``) have no
        entries: their ``(scene, spp)`` is returned as given (spp 0 when None).

        Raises:
            UnknownNameError: no key or several keys match, or the spp is ambiguous; the message
                lists the candidates.
        """
        if denoiser not in GRIDS:
            return scene, 0 if spp is None else spp
        by_scene = self.entries.get(denoiser, {})
        keys = (
            [scene]
            if scene in by_scene
            else sorted(k for k in by_scene if k.split("/")[0] == scene)
        )
        if len(keys) != 1:
            raise UnknownNameError(
                f"tuned params: expected one {denoiser} entry for scene {scene!r}, got "
                f"{len(keys)}: {', '.join(keys or sorted(by_scene)) or 'nothing stored'}"
            )
        if spp is not None:
            return keys[0], spp
        spps = sorted(by_scene[keys[0]], key=int)
        if len(spps) != 1:
            raise UnknownNameError(
                f"tuned params: expected --spp for {denoiser}/{keys[0]}, which holds "
                f"{', '.join(spps)} spp"
            )
        return keys[0], int(spps[0])

    def save(self, path: str | Path) -> None:
        """Write the store as JSON (sorted keys, so equal stores give equal files), atomically."""
        text = json.dumps(
            {"format": PARAMS_FORMAT, "entries": self.entries}, indent=1, sort_keys=True
        )
        _atomic_write_text(Path(path), text + "\n")

    @classmethod
    def load(cls, path: str | Path) -> ParamStore:
        """Read a store written by :meth:`save`.

        Raises:
            FileFormatError: the file is missing, not JSON, or not a tuned-parameters file.
        """
        path = Path(path)
        try:
            payload = json.loads(path.read_text())
        except FileNotFoundError:
            raise FileFormatError(
                f"{path}: expected a tuned-parameters file, got no such file"
            ) from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
            raise FileFormatError(
                f"{path}: expected a tuned-parameters JSON file, got {err}"
            ) from None
        if not isinstance(payload, dict) or payload.get("format") != PARAMS_FORMAT:
            got = payload.get("format") if isinstance(payload, dict) else type(payload).__name__
            raise FileFormatError(f"{path}: expected format {PARAMS_FORMAT!r}, got {got!r}")
        entries = payload.get("entries")
        if not isinstance(entries, dict):
            raise FileFormatError(
                f"{path}: expected an 'entries' object, got {type(entries).__name__}"
            )
        return cls(entries)


def tuned_denoiser(name: str, scene: str, spp: int, store: ParamStore) -> Denoiser:
    """The denoiser ``name`` with its tuned parameters for ``scene`` at ``spp``.

    Denoisers without a grid (``unet``, ``oidn``) are built with their defaults.
    """
    if name not in GRIDS:
        return get_denoiser(name)
    return get_denoiser(name, **store.params(name, scene, spp))

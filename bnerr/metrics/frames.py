"""The metrics' table, and their update over frames and compute with bootstrap intervals.

**The table.** :data:`METRIC_TABLE` maps each metric's name to a :class:`Metric`: its update (one
image -> its pair, a method of :class:`~bnerr.metrics.image.ImagePair` or any function of one) and
how summary tables show it (``benchmarks/reports/table.py`` takes ``table.csv``'s metric columns
from it). :data:`METRICS`, the shipped names in table order, is derived from it. Adding a metric is
one update function and one table entry; :class:`FrameMetrics` and the report need no change.

**Plug-in metrics** (:mod:`bnerr.plugins`): a function ``metric(pred [C, H, W], ref [C, H, W])
-> scalar`` (with a ``mask`` parameter it also gets the region's ``[H, W]`` bool mask; without
one, in a region's rows it scores ``pred`` with every pixel outside the region replaced by the
reference's, no error there: a maximum is the region's, a mean over pixels the region's times
its share, which a ratio to white cancels), given as a spec (:func:`load_metric`) or installed
as an entry point of the group ``bnerr.metrics``, joins :data:`METRIC_TABLE` after the shipped
entries, under its ``name`` attribute (else the spec's or entry point's name); its row in
summary tables is described by optional attributes on the function: ``description`` (else its
docstring's first line), ``interval``, ``ratio`` and ``group`` (as :class:`Metric`'s). A
:class:`Metric` itself is a plug-in too.

**Update and compute** (the split of torchmetrics' ``_psnr_update`` / ``_psnr_compute``).
Each metric's update reduces one frame to a pair ``(numerator, denominator)`` (``(sum e^2,
pixel count)`` for the MSE family, ``(value, 1)`` for per-image scores such as PSNR and SSIM), and
the compute step is ``sum(numerators) / sum(denominators)`` over frames
(:func:`bnerr.metrics.stats.pooled_mean`). One frame gives the per-image value; many frames give
the pooled running mean; its interval is a t-interval over the seed sets' pooled means
(:mod:`bnerr.metrics.stats`).

**Windows** (the temporal metrics, :mod:`bnerr.metrics.temporal`). A metric whose ``window`` is
above 1 sees the frames before the current one too: :class:`FrameMetrics` keeps, per seed set, the
last ``window - 1`` frames it was given and calls its update with the consecutive ones that end at
the current frame (oldest first, at most ``window``); a frame whose region held no pixel
(:meth:`FrameMetrics.update_empty`) ends a window. Only the frames given count: a sweep gives its
measured frames, never the warmup, so a pair of frames is measured only when both are.

**Sequences** (ColorVideoVDP, :mod:`bnerr.metrics.cvvdp`). A metric whose ``sequence`` is set
scores a seed set's whole sequence at once, a value no frame has alone: :class:`FrameMetrics`
keeps the seed set's frames and calls its update once per sequence, with all of them (oldest
first), when the pairs are read (:meth:`FrameMetrics.stats`), and every frame of the sequence gets
the pair it returns (``(J, 1)``: the pooled mean of the seed set is ``J``). A frame whose region
held no pixel ends the sequence (the next frame starts another); frames added after the pairs
were read extend their sequence, which is scored again. :meth:`FrameMetrics.update` gives such a
metric's per-frame value as NaN (not known before the sequence ends).

Not for: the error's correlation from frame to frame along the motion
(:func:`bnerr.metrics.image.temporal_correlation`, measured beside the table).
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import torch

from bnerr import plugins
from bnerr.errors import (
    PluginError,
    ShapeError,
    ValueRangeError,
    check_name,
    check_positive_int,
)
from bnerr.metrics.cvvdp import cvvdp_sequence, require_cvvdp
from bnerr.metrics.image import ImagePair, PreparedReference, require_flip
from bnerr.metrics.stats import Estimate, bootstrap_interval, paired_ratio, pooled_mean
from bnerr.metrics.temporal import (
    TAVG_FRAMES,
    frame_difference_mse,
    frame_difference_relmse,
    window_average_mse,
)

__all__ = ["BLUR_SIGMAS", "METRICS", "METRIC_TABLE", "FrameMetrics", "Metric", "load_metric"]


@dataclass(frozen=True)
class Metric:
    """One entry of :data:`METRIC_TABLE`: how a frame updates the metric, and how tables show it.

    Attributes:
        update: ``update(pair: ImagePair) -> [2]`` float64, the frame's ``(numerator,
            denominator)`` on ``pair.pred``'s device (:meth:`ImagePair.score` makes the pair of a
            per-image value); with a ``window`` above 1, ``update(pairs: tuple[ImagePair, ...])``,
            the consecutive frames of the seed set that end at the current one (oldest first,
            1 to ``window`` of them).
        default: measured by a :class:`FrameMetrics` given no names.
        require: called when a :class:`FrameMetrics` with the metric is made; raises when the
            metric cannot run (an optional package missing), so that a run fails before it starts.
        interval: summary tables give the pooled value's bootstrap interval (``_lo``, ``_hi``),
            before and after denoising.
        ratio: summary tables give the paired ratio to the white-noise baseline with its interval.
        difference: summary tables give the paired difference to the white-noise baseline with
            its interval (a score on an interval scale, where a ratio means nothing: JOD).
        group: the metrics of one group sit side by side in summary tables (each one's raw value,
            then each one's denoised value); None: a group of its own.
        tabled: summary tables give the metric columns at all.
        description: what the row measures, in words (a plug-in's; "" for the shipped ones,
            which docs/METHODS.md describes).
        window: the most frames of a seed set the update sees at once (1: the current frame).
        sequence: the update scores a seed set's whole sequence, ``update(pairs: tuple[ImagePair,
            ...]) -> [2]`` once per sequence (the module docstring); ``window`` is then unused.
    """

    update: Callable[[Any], torch.Tensor]
    default: bool = True
    require: Callable[[], None] | None = None
    interval: bool = False
    ratio: bool = False
    difference: bool = False
    group: str | None = None
    tabled: bool = True
    description: str = ""
    window: int = 1
    sequence: bool = False


#: A sequence metric's pair before its sequence is scored (:meth:`FrameMetrics.stats` scores it).
_UNSCORED = torch.tensor([math.nan, 0.0], dtype=torch.float64)

#: Gaussian blur widths (pixels) of the blurred-MSE metrics ``mse_blur1`` and ``mse_blur2``.
BLUR_SIGMAS: dict[str, float] = {"mse_blur1": 1.0, "mse_blur2": 2.0}


@dataclass(frozen=True)
class _PluginUpdate:
    """The update of a plug-in metric ``fn(pred, ref[, mask]) -> scalar``: its value as a score."""

    fn: Callable[..., object]
    plugin: plugins.Plugin
    masked: bool

    def __call__(self, pair: ImagePair) -> torch.Tensor:
        extra = {"mask": pair.mask} if self.masked else {}
        pred = pair.pred
        if pair.mask is not None and not self.masked:  # region-blind: no error outside it
            pred = torch.where(pair.mask, pair.pred, pair.ref.color)
        value = plugins.call_plugin(self.plugin, "metric", self.fn, pred, pair.ref.color, **extra)
        try:
            number = float(value)  # type: ignore[arg-type,unused-ignore]
        except (TypeError, ValueError, RuntimeError):
            number = math.nan
        if not math.isfinite(number):
            raise PluginError(
                f"{self.plugin.who}: expected the metric to return a finite scalar, got {value!r}"
            )
        return pair.score(number)


def _adapt(plugin: plugins.Plugin) -> tuple[str, Metric]:
    """A metric plug-in checked and made a table entry (see the module docstring)."""
    obj = plugin.obj
    if isinstance(obj, Metric):
        return plugins.plugin_name(plugin, "metric"), obj
    if not callable(obj) or isinstance(obj, type):
        raise PluginError(
            f"{plugin.who}: expected a metric function (pred, ref) -> scalar or a "
            f"bnerr.metrics.frames.Metric, got {type(obj).__name__}"
        )
    try:
        masked = "mask" in inspect.signature(obj).parameters
    except (TypeError, ValueError):
        masked = False
    doc = (inspect.getdoc(obj) or "").strip().splitlines()
    metric = Metric(
        _PluginUpdate(obj, plugin, masked),
        default=False,
        interval=bool(getattr(obj, "interval", False)),
        ratio=bool(getattr(obj, "ratio", False)),
        group=getattr(obj, "group", None),
        description=str(getattr(obj, "description", "") or (doc[0] if doc else "")),
    )
    return plugins.plugin_name(plugin, "metric"), metric


#: Every metric :class:`FrameMetrics` knows, by name, in table order (``table.csv``'s column
#: order): the shipped ones, then the plug-ins (installed entry points of ``bnerr.metrics``, read
#: the first time the table is; loaded specs, :func:`load_metric`).
METRIC_TABLE: dict[str, Metric] = plugins.PluginRegistry(
    "bnerr.metrics",
    _adapt,
    {
        "mse": Metric(ImagePair.mse, interval=True, ratio=True),
        "relmse": Metric(ImagePair.relmse),
        "psnr": Metric(ImagePair.psnr),
        "ssim": Metric(ImagePair.ssim),
        **{
            name: Metric(
                functools.partial(ImagePair.blurred, sigma=sigma), ratio=True, group="blur"
            )
            for name, sigma in BLUR_SIGMAS.items()
        },
        "lowfreq": Metric(ImagePair.lowfreq),
        # Flicker (bnerr.metrics.temporal): over consecutive measured frames of a seed set.
        "tmse": Metric(frame_difference_mse, interval=True, ratio=True, group="flicker", window=2),
        "trelmse": Metric(frame_difference_relmse, group="flicker", window=2),
        "mse_tavg": Metric(
            window_average_mse, interval=True, ratio=True, group="flicker", window=TAVG_FRAMES
        ),
        # FLIP needs an optional package and about 0.5 s per 256x256 image: measured only when
        # named. Its ratio to white is a perceptual verdict (benchmarks/reports/perceptual.py);
        # its columns stay empty where it was not measured.
        "flip": Metric(ImagePair.flip, default=False, require=require_flip, ratio=True),
        # ColorVideoVDP's JOD of each seed set's sequence (bnerr.metrics.cvvdp): higher is
        # better, so tables give its difference to white, not a ratio. About 0.14 s per sequence
        # of 3 frames and image kind: measured only when named (a suite's metrics).
        "cvvdp": Metric(
            cvvdp_sequence,
            default=False,
            require=require_cvvdp,
            interval=True,
            difference=True,
            sequence=True,
        ),
    },
    sort=False,
)

#: Every shipped metric's name, in table order. ``flip`` needs ``flip-evaluator``, ``cvvdp`` the
#: package ``cvvdp``.
METRICS: tuple[str, ...] = tuple(dict.keys(METRIC_TABLE))


def load_metric(name_or_spec: str) -> str:
    """The registered name of ``name_or_spec``: itself when in :data:`METRIC_TABLE` (or not a
    spec), else the plug-in metric it specifies, loaded and added to the table."""
    if name_or_spec in METRIC_TABLE or not plugins.is_spec(name_or_spec):
        return name_or_spec
    table = METRIC_TABLE
    assert isinstance(table, plugins.PluginRegistry)
    return table.add(plugins.resolve(name_or_spec))


@dataclass
class _Sequence:
    """One sequence of a seed set: each frame's slot in the pairs and its pair, how many of its
    frames the pairs were last scored with, and whether a frame may still join it."""

    slots: list[int] = field(default_factory=list)
    pairs: list[ImagePair] = field(default_factory=list)
    scored: int = 0
    open: bool = True


class FrameMetrics:
    """Metrics of a sequence of frames against their references: update per frame, compute over all.

    Keeps, per metric, each frame's ``(numerator, denominator)`` pair (see the module docstring),
    so that the running mean, the bootstrap interval and a paired ratio to another run all come
    from the same numbers.

    Example::

        acc = FrameMetrics(["mse", "mse_blur1"])
        for t in frames:
            acc.update(denoised[t], reference[t])
        acc.compute()["mse"]                 # Estimate(value, lo, hi, n)
        acc.ratio(white_acc, "mse")           # paired ratio to white over the same frames

    Args:
        names: metric names from :data:`METRIC_TABLE` (default: its ``default`` ones, all but
            ``flip`` and ``cvvdp``, which are slow).
        tile: tile size of the ``lowfreq`` spectrum (clamped to the image by the spectrum).
    """

    def __init__(self, names: Iterable[str] | None = None, *, tile: int = 64) -> None:
        table = dict(METRIC_TABLE)  # read now, not at import: an entry added since counts
        default = tuple(name for name, metric in table.items() if metric.default)
        chosen = tuple(names) if names is not None else default
        for name in chosen:
            check_name(name, tuple(table), "metric")
        for name in chosen:
            require = table[name].require
            if require is not None:
                require()  # before any frame: a run fails before it starts
        self.names = chosen
        self.tile = check_positive_int(tile, "tile", minimum=2)
        self._updates = {name: table[name].update for name in chosen}
        self._sequences = tuple(name for name in chosen if table[name].sequence)
        self._windows = {
            name: 1 if name in self._sequences else check_positive_int(table[name].window, "window")
            for name in chosen
        }
        self._runs: dict[int, list[_Sequence]] = {}  # per seed set, its sequences
        # per seed set, the last frames a windowed metric needs (None: a frame without pixels)
        self._keep = max(self._windows.values(), default=1) - 1
        self._recent: dict[int, list[ImagePair | None]] = {}
        self._stats: dict[str, list[torch.Tensor]] = {name: [] for name in chosen}
        self._groups: list[int] = []

    def _remember(self, group: int, pair: ImagePair | None) -> None:
        """Keep ``pair`` as the latest frame of seed set ``group`` (the last ``window - 1``)."""
        if self._keep:
            recent = self._recent.setdefault(group, [])
            recent.append(pair)
            del recent[: -self._keep]

    def _window(self, group: int, pair: ImagePair) -> list[ImagePair]:
        """The consecutive frames of seed set ``group`` that end at ``pair``, oldest first."""
        frames = [pair]
        for before in reversed(self._recent.get(group, [])):
            if before is None:
                break
            frames.insert(0, before)
        return frames

    def _update_one(self, name: str, pair: ImagePair, frames: list[ImagePair]) -> torch.Tensor:
        window = self._windows[name]
        if window == 1:
            return self._updates[name](pair)
        return self._updates[name](tuple(frames[-window:]))

    def update(
        self,
        pred: torch.Tensor,
        ref: torch.Tensor | PreparedReference,
        mask: torch.Tensor | None = None,
        group: int = 0,
    ) -> dict[str, float]:
        """Add one frame; return its per-frame value of every metric.

        Args:
            pred: ``[C, H, W]`` as in :func:`bnerr.metrics.mse`.
            ref: its reference ``[C, H, W]``, or a :class:`PreparedReference` of it (the same
                values, computed faster when several images are measured against one reference).
            mask: optional ``[H, W]`` bool restricting every metric except ``lowfreq``.
            group: index of the independent seed set the frame belongs to (0 when there is one);
                a windowed metric's window holds this seed set's frames only.
        """
        return self.update_pair(ImagePair(pred, ref, mask, tile=self.tile), group)

    def update_pair(self, pair: ImagePair, group: int = 0) -> dict[str, float]:
        """Add one frame given as its :class:`ImagePair` (an image measured in several pixel
        regions passes the pairs :meth:`ImagePair.in_region` makes of it, which compute its
        whole-image maps once); as :meth:`update` otherwise.

        Raises:
            ValueRangeError: the pair's ``tile`` is not this accumulator's (``lowfreq`` would
                read another spectrum).
        """
        if pair.tile != self.tile:
            raise ValueRangeError(
                f"pair: expected the accumulator's lowfreq tile {self.tile}, got {pair.tile}"
            )
        check_positive_int(group, "group", minimum=0)
        frames = self._window(group, pair)
        row = {
            name: self._update_one(name, pair, frames)
            for name in self.names
            if name not in self._sequences
        }
        for name in self.names:
            stats = row.get(name)  # a sequence's pair is written when it is scored
            self._stats[name].append(_UNSCORED if stats is None else stats.cpu())
        if self._sequences:
            self._extend_sequence(group, pair)
        self._groups.append(group)
        self._remember(group, pair.error_only())
        values = {name: float(pooled_mean(stats)) for name, stats in row.items()}
        return {name: values.get(name, math.nan) for name in self.names}

    def _extend_sequence(self, group: int, pair: ImagePair) -> None:
        """Add the frame (its slot: the next in the pairs) to the seed set's open sequence."""
        runs = self._runs.setdefault(group, [])
        if not runs or not runs[-1].open:  # none yet, or the last one ended by an empty frame
            runs.append(_Sequence())
        runs[-1].slots.append(len(self._groups))
        runs[-1].pairs.append(pair.bare())

    def _score_sequences(self) -> None:
        """Score every sequence not scored at its current length, once for all its frames."""
        for runs in self._runs.values():
            for seq in runs:
                if seq.scored == len(seq.pairs):
                    continue
                for name in self._sequences:
                    stats = self._updates[name](tuple(seq.pairs)).to(torch.float64).cpu()
                    for slot in seq.slots:
                        self._stats[name][slot] = stats
                seq.scored = len(seq.pairs)

    def update_empty(self, group: int = 0) -> None:
        """Add a frame in which the region measured holds no pixel (a coherent region that the
        frame lacks): ``(0, 0)`` pairs, which keep the frame count of its seed set and weigh
        nothing in the pooled means (all-empty frames pool to NaN: nothing was measured). It ends
        the seed set's window: the next frame's temporal metrics start afresh."""
        check_positive_int(group, "group", minimum=0)
        for name in self.names:
            self._stats[name].append(torch.zeros(2, dtype=torch.float64))
        for seq in self._runs.get(group, [])[-1:]:
            seq.open = False  # the next frame starts another sequence
        self._groups.append(group)
        self._remember(group, None)

    def __len__(self) -> int:
        return len(self._groups)

    def stats(self, name: str) -> torch.Tensor:
        """Per-frame ``(numerator, denominator)`` pairs of metric ``name``: ``[S, F, 2]`` float64.

        Frames are grouped by seed set in the order they were added; every seed set must hold the
        same number of frames.
        """
        check_name(name, self.names, "metric")
        if not self._groups:
            raise ValueRangeError("FrameMetrics: expected at least one frame, got none")
        if name in self._sequences:
            self._score_sequences()
        groups = torch.tensor(self._groups)
        stats = torch.stack(self._stats[name])
        order = torch.argsort(groups, stable=True)
        counts = torch.bincount(groups[order])
        counts = counts[counts > 0]
        if bool((counts != counts[0]).any()):
            raise ShapeError(
                f"FrameMetrics: expected equal frames per seed set, got {counts.tolist()}"
            )
        return stats[order].reshape(counts.numel(), int(counts[0]), 2)

    def values(self, name: str) -> torch.Tensor:
        """Per-frame values of metric ``name``: ``[S, F]`` float64."""
        stats = self.stats(name)
        return stats[..., 0] / stats[..., 1]

    def compute(
        self, level: float = 0.95, resamples: int = 2000, seed: int = 0
    ) -> dict[str, Estimate]:
        """Every metric's pooled mean over the frames with its interval
        (:func:`bnerr.metrics.stats.bootstrap_interval`: a t-interval over seed sets; ``resamples``
        and ``seed`` are for its ``method="bootstrap"`` and unused here)."""
        return {
            name: bootstrap_interval(self.stats(name), level, resamples, seed)
            for name in self.names
        }

    def ratio(
        self,
        baseline: FrameMetrics,
        name: str,
        level: float = 0.95,
        resamples: int = 2000,
        seed: int = 0,
    ) -> Estimate:
        """Paired ratio of this run's metric ``name`` to ``baseline``'s over the same frames, with
        :func:`bnerr.metrics.stats.paired_ratio`'s interval (a t-interval over seed sets)."""
        return paired_ratio(self.stats(name), baseline.stats(name), level, resamples, seed)

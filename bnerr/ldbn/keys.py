"""Optimizing a whole set of LDBN key tiles, resumably, and loading the shipped ones.

:func:`optimize_keys` runs one job per (level, dimension pair): level ``l`` is the tile for
``N = 2^l`` samples (docs/METHODS.md, section 10):

1. **Scrambling keys.** ``F T^2`` random 24-bit key pairs; each key's error vector is the
   estimate of every test integrand by the N points ``shared[0:N] XOR key`` of the pair's shared
   sequence; :func:`bnerr.ldbn.swaps.swap_descent` permutes the keys over the tile.
2. **Ranking keys, one bit at a time from the top** (OpenQMC's progressive procedure): for
   ``m = N/2, ..., 1`` every texel chooses whether its first m samples are the lower or the upper
   half of the 2m-block the larger prefixes chose (:func:`bnerr.ldbn.swaps.flip_descent`), so every
   power-of-two prefix is blue given the larger ones.

With ``joint`` every pair past the first (the pixel jitter) is optimized *with* it: its ranking
keys are the first pair's (sample i reads index ``i XOR rank`` in both pairs, so each texel's 4D
point set is fixed once its light keys are), and its scrambling keys are permuted over the tile
on 4D test integrands of both pairs, the first pair's keys fixed
(:func:`bnerr.ldbn.swaps.joint_swap_descent`): with several jittered samples each light sample
meets another shading point, and the 2D tests do not see that interaction (docs/METHODS.md,
section 10).

**Rounds.** The (level, pair) jobs are independent (but for the joint ones), so they run in
rounds, batched (:func:`bnerr.ldbn.swaps.swap_descents`, :func:`~bnerr.ldbn.swaps.flip_descents`):
round 0 permutes every job's scrambling keys, round r >= 1 chooses ranking bit r of every job of
a level >= r. Each job draws from its own seeds, so its keys do not depend on which jobs share
its round. The run follows ``device`` (``cpu`` or ``cuda``): the same options give the same keys
on one device, different keys on another (docs/METHODS.md, section 10).

After each round the checkpoint (``.npz``, compressed, written atomically) holds every job's
keys and the number of its stages done; a rerun with the same options skips them, so an
interrupted run (or one stopped at its ``deadline``) resumes where it stopped. With the same
arguments on one device the result is the same bit for bit. The key sets before this batching
(the shipped 64 x 64 ones) were made by the sequential descent, one job after another; the
batched one does not reproduce them bit for bit.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from bnerr.errors import FileFormatError, ValueRangeError, check_positive_int
from bnerr.hashing import lowbias32_host, signed32
from bnerr.io import atomic_write
from bnerr.ldbn.integrands import (
    Integrands,
    error_features,
    estimates,
    feature_basis,
    make_integrands,
)
from bnerr.ldbn.swaps import (
    Progress,
    energy_kernel,
    flip_descents,
    joint_swap_descent,
    measured_kernel,
    swap_descents,
)
from bnerr.resources import load_array, shipped_files
from bnerr.sequences.ldbn import LDBNKeys
from bnerr.sequences.ldbn_bases import (
    base_table,
    check_base,
    keyed_words,
    morton_chunks,
)

__all__ = [
    "KIND_BASES",
    "SHIPPED_SEED0",
    "KeyOptions",
    "keys_from_array",
    "load_ldbn_keys",
    "optimize_keys",
    "run_keys",
    "shipped_ldbn",
    "ldbn_file_name",
    "write_keys",
]

_TWO_24 = 1 << 24

#: The shared sequence's seed of the shipped key sets: among seeds 0..23, the one whose digital
#: shifts by random keys come closest to per-pixel Owen scrambling in MSE on the test integrands
#: (worst pair 1.07x at 2-16 samples; seed 0: 1.14x; docs/METHODS.md, section 10).
SHIPPED_SEED0 = 18


@dataclass(frozen=True)
class KeyOptions:
    """What a key set is optimized for (every field goes into the checkpoint and the file).

    Attributes:
        size: T, the tile side. levels: L, tiles for 1, 2, ..., 2^(L-1) samples. dims: D (even).
        frames: F, the frame axis (1: a screen tile; > 1: spatiotemporal, ``ldbn_st``).
        sigma: the kernel's width (Heitz's 2.1), or the filter's sigma with ``autocorrelation``.
        autocorrelation: target a Gaussian filter of ``sigma`` (``ldbn_fast``).
        sigma_t: the temporal kernel's width in frames (F > 1).
        tests: test integrands; components: principal components kept; iterations: per stage.
        seed: random start and test integrands; seed0: the shared sequence's seed.
        joint: optimize the pairs past the first jointly with it (module docstring).
        device: the torch device the descents run on (``cpu``, ``cuda``, ``cuda:1``); the
            keys differ between devices (module docstring).
        kernel: None, or a measured filter's autocorrelation ``[K, K]`` (K odd, centred) as
            nested tuples: the energy's spatial kernel instead of ``sigma``'s Gaussian
            (:func:`bnerr.ldbn.swaps.measured_kernel`; ``python -m bnerr.ldbn.matched``).
        base: the base point set the keys act on (:mod:`bnerr.sequences.ldbn_bases`):
            ``sobol`` (the shipped sets), ``lattice`` (random rotations permuted over the tile)
            or ``zorder`` (chunks permuted, from the Morton order); the last two are screen
            tiles (``frames`` 1), ``zorder`` on a power-of-two side.
    """

    size: int = 64
    levels: int = 5
    dims: int = 8
    frames: int = 1
    sigma: float = 2.1
    autocorrelation: bool = False
    sigma_t: float = 1.9
    tests: int = 256
    components: int = 32
    iterations: int = 600
    seed: int = 0
    seed0: int = SHIPPED_SEED0
    joint: bool = False
    device: str = "cpu"
    kernel: tuple[tuple[float, ...], ...] | None = None
    base: str = "sobol"

    def __post_init__(self) -> None:
        try:
            torch.device(self.device)
        except (RuntimeError, TypeError) as err:
            raise ValueRangeError(
                f"device: expected a torch device such as 'cpu' or 'cuda', got {self.device!r}"
            ) from err
        check_positive_int(self.size, "size", minimum=2)
        check_positive_int(self.levels, "levels")
        check_positive_int(self.frames, "frames")
        check_positive_int(self.iterations, "iterations")
        check_positive_int(self.tests, "tests", minimum=2)
        if check_positive_int(self.dims, "dims", minimum=2) % 2:
            raise ValueRangeError(f"dims: expected an even number (pairs), got {self.dims}")
        if self.levels > 12:
            raise ValueRangeError(f"levels: expected at most 12 (4096 spp), got {self.levels}")
        if self.kernel is not None:
            self.energy_kernel()  # checks its shape and values
        if check_base(self.base) != "sobol" and self.frames > 1:
            raise ValueRangeError(
                f"base {self.base!r}: expected a screen tile (frames 1), got frames {self.frames}"
            )
        if self.base == "zorder":
            morton_chunks(self.size)  # checks the side

    def energy_kernel(self) -> torch.Tensor:
        """The energy's kernel ``w [F, T, T]``: the measured one, else ``sigma``'s Gaussian."""
        if self.kernel is None:
            return energy_kernel(
                self.size, self.frames, self.sigma, self.sigma_t, self.autocorrelation
            )
        auto = torch.tensor(self.kernel, dtype=torch.float64)
        return measured_kernel(auto, self.size, self.frames, self.sigma_t)

    def to_json(self) -> str:
        """The options as the checkpoint records them (``kernel`` only when set and ``base``
        only when not ``sobol``, so that a checkpoint written before the fields existed still
        resumes)."""
        fields = asdict(self)
        if fields["kernel"] is None:
            del fields["kernel"]
        if fields["base"] == "sobol":
            del fields["base"]
        return json.dumps(fields, sort_keys=True)

    def is_joint(self, pair: int) -> bool:
        """Whether ``pair`` is optimized jointly with the first (module docstring)."""
        return self.joint and pair > 0

    def stages(self, level: int, pair: int) -> int:
        """Descent runs of one job: the scrambling keys, then one per ranking bit (none when
        the pair is joint: it takes the first pair's ranks)."""
        return 1 if self.is_joint(pair) else 1 + level

    def steps(self) -> int:
        """Descent iterations of the whole run (the progress bar's total)."""
        return self.iterations * sum(
            self.stages(level, pair)
            for level in range(self.levels)
            for pair in range(self.dims // 2)
        )


class _Job:
    """One (level, pair) job's inputs: the shared words, the tests, the kernel and the RNG."""

    def __init__(self, opts: KeyOptions, level: int, pair: int) -> None:
        self.n = 1 << level
        self.level = level
        self.texels = opts.frames * opts.size * opts.size
        self.base = opts.seed * 1_000_003 + level * 1009 + pair
        self.gen = torch.Generator().manual_seed(self.base)
        self.device = torch.device(opts.device)
        table = base_table(opts.base, opts.seed0, pair, level, self.texels)
        self.table = table.to(self.device)
        self.tests: Integrands = make_integrands(opts.tests, opts.seed * 7919 + pair)
        self.kernel = opts.energy_kernel()
        self.opts = opts
        self.pair = pair

    def seed(self, stage: int) -> int:
        """The int32 seed of this job's descent in ``stage`` (its draws: bnerr.ldbn.swaps)."""
        return signed32(lowbias32_host(lowbias32_host(self.base) ^ (stage * 0x9E3779B9)))

    def features(self, indices: torch.Tensor, keys: torch.Tensor) -> torch.Tensor:
        """Error features of the base's point sets ``indices [K, m]`` read through ``keys
        [K, 2]`` (:func:`bnerr.sequences.ldbn_bases.keyed_words`): ``[K, C]``."""
        words = keyed_words(self.opts.base, self.table, indices, keys, self.n)
        points = words.float() / _TWO_24
        return error_features(estimates(points, self.tests), self.opts.components)

    def random_keys(self) -> torch.Tensor:
        """``[P, 2]`` the scrambling keys the swaps permute: random words drawn on the CPU, or
        for ``zorder`` the texels' Morton chunks (second channel 0)."""
        keys = torch.randint(0, _TWO_24, (self.texels, 2), generator=self.gen)
        if self.opts.base == "zorder":
            keys = torch.stack([morton_chunks(self.opts.size), torch.zeros_like(keys[:, 0])], 1)
        return keys.to(self.device)

    def scramble_features(self, keys: torch.Tensor) -> torch.Tensor:
        """``[P, C]`` the features of the keys ``[P, 2]`` on the tile's first N indices."""
        indices = torch.arange(self.n, device=self.device).expand(self.texels, -1)
        return self.features(indices, keys)

    def rank_options(self, keys: torch.Tensor, rank: torch.Tensor, m: int) -> torch.Tensor:
        """``[2, P, C]`` the features of each texel's first ``m`` samples as the lower or the
        upper half of the 2m-block its larger prefixes (``rank [P]``) chose."""
        starts = torch.stack([rank, rank + m])  # [2, P]
        indices = starts[..., None] + torch.arange(m, device=self.device)  # [2, P, m]
        both = self.features(indices.reshape(-1, m), keys.repeat(2, 1))
        return both.reshape(2, self.texels, -1)

    def joint_scramble(
        self, first: torch.Tensor, rank: torch.Tensor, progress: Progress | None
    ) -> torch.Tensor:
        """This pair's scrambling keys on 4D tests of it and the first pair, whose keys
        ``first [P, 2]`` and ranks ``rank [P]`` (shared by both pairs) are fixed (on the CPU);
        the start is :meth:`random_keys` (the Morton chunks for ``zorder``)."""
        keys = self.random_keys().cpu()
        base, n = self.opts.base, self.n
        index = torch.arange(n)[None, :] ^ rank[:, None]  # [P, N]
        table0 = base_table(base, self.opts.seed0, 0, self.level, self.texels)
        jitter = keyed_words(base, table0, index, first, n).float() / _TWO_24  # [P, N, 2]
        table = self.table.cpu()
        tests = make_integrands(self.opts.tests, self.opts.seed * 7919 + 104729 + self.pair, 4)

        def values(texels: torch.Tensor, rows: torch.Tensor) -> torch.Tensor:
            light = keyed_words(base, table, index[texels], keys[rows], n).float() / _TWO_24
            return estimates(torch.cat([jitter[texels], light], 2), tests)

        every = torch.arange(self.texels)
        basis = feature_basis(values(every, every), self.opts.components)
        perm = joint_swap_descent(
            lambda t, r: basis.project(values(t, r)),
            self.kernel,
            self.opts.iterations,
            self.gen,
            progress,
        )
        return keys[perm]


def _empty(opts: KeyOptions) -> dict[str, np.ndarray]:
    shape = (opts.levels, opts.frames, opts.size, opts.size)
    return {
        "scramble": np.zeros((*shape, opts.dims), np.int32),
        "rank": np.zeros((*shape, opts.dims // 2), np.int32),
        "stage": np.zeros((opts.levels, opts.dims // 2), np.int32),
    }


def _load_checkpoint(path: Path | None, opts: KeyOptions) -> dict[str, np.ndarray]:
    if path is None or not path.exists():
        return _empty(opts)
    with np.load(path, allow_pickle=False) as data:
        if str(data["options"]) != opts.to_json():
            raise FileFormatError(
                f"{path}: expected a checkpoint of options {asdict(opts)}, got {data['options']}"
            )
        return {k: data[k].copy() for k in ("scramble", "rank", "stage")}


def _save_checkpoint(path: Path, opts: KeyOptions, state: dict[str, np.ndarray]) -> None:
    with atomic_write(path) as tmp, open(tmp, "wb") as f:
        arrays: dict[str, np.ndarray] = {"options": np.array(opts.to_json())}
        np.savez_compressed(f, **arrays, **state)  # type: ignore[arg-type]


def _store(state: dict[str, np.ndarray], job: _Job, keys: torch.Tensor, rank: torch.Tensor) -> None:
    """Write one job's scrambling keys ``[P, 2]`` and (partial) ranks ``[P]`` into the state."""
    shape = state["rank"].shape[1:4]
    pairs = slice(2 * job.pair, 2 * job.pair + 2)
    state["scramble"][job.level, ..., pairs] = keys.reshape(*shape, 2).cpu().numpy()
    state["rank"][job.level, ..., job.pair] = rank.reshape(shape).cpu().numpy()


def _job_keys(state: dict[str, np.ndarray], job: _Job) -> tuple[torch.Tensor, torch.Tensor]:
    """One job's scrambling keys ``[P, 2]`` and ranks so far ``[P]`` from the state."""
    pairs = slice(2 * job.pair, 2 * job.pair + 2)
    keys = torch.from_numpy(state["scramble"][job.level, ..., pairs].reshape(-1, 2)).long()
    rank = torch.from_numpy(state["rank"][job.level, ..., job.pair].reshape(-1)).long()
    return keys.to(job.device), rank.to(job.device)


def _run_round(
    opts: KeyOptions,
    state: dict[str, np.ndarray],
    jobs: list[_Job],
    stage: int,
    steps: tuple[Progress | None, float | None],
) -> bool:
    """Stage ``stage`` of every job at once (module docstring); False if the deadline passed."""
    progress, deadline = steps
    device = jobs[0].device
    seeds = torch.tensor([job.seed(stage) for job in jobs], dtype=torch.int32, device=device)
    kernel = jobs[0].kernel
    if stage == 0:
        keys = [job.random_keys() for job in jobs]
        feats = torch.stack([job.scramble_features(k) for job, k in zip(jobs, keys)])
        perms = swap_descents(feats, kernel, opts.iterations, seeds, progress, deadline)
        if perms is None:
            return False
        for job, k, perm in zip(jobs, keys, perms):
            _store(state, job, k[perm], torch.zeros_like(perm))
    else:
        current = [_job_keys(state, job) for job in jobs]
        feats = torch.stack(
            [job.rank_options(k, r, job.n >> stage) for job, (k, r) in zip(jobs, current)]
        )
        choices = flip_descents(feats, kernel, opts.iterations, seeds, progress, deadline)
        if choices is None:
            return False
        for job, (k, r), choice in zip(jobs, current, choices):
            _store(state, job, k, r + choice * (job.n >> stage))
    for job in jobs:
        state["stage"][job.level, job.pair] = stage + 1
    return True


def _run_joint(
    job: _Job, state: dict[str, np.ndarray], progress: Progress | None
) -> tuple[torch.Tensor, torch.Tensor]:
    """One joint job's scrambling keys ``[P, 2]`` and the first pair's ranks ``[P]``."""
    if state["stage"][job.level, 0] < job.opts.stages(job.level, 0):
        raise ValueRangeError(
            f"level {job.level}: the first pair must be optimized before pair {job.pair}"
        )
    first = torch.from_numpy(state["scramble"][job.level, ..., 0:2].reshape(-1, 2)).long()
    rank = torch.from_numpy(state["rank"][job.level, ..., 0].reshape(-1)).long()
    return job.joint_scramble(first, rank, progress), rank


def run_keys(
    opts: KeyOptions,
    checkpoint: str | Path | None = None,
    progress: Progress | None = None,
    deadline: float | None = None,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """:func:`optimize_keys` that may stop at a ``deadline`` (``time.monotonic()`` seconds).

    Returns:
        ``(scramble, rank, finished)``: the keys so far (the checkpoint's, when one is given)
        and whether every job is done; a rerun with the checkpoint continues.
    """
    path = None if checkpoint is None else Path(checkpoint)
    state = _load_checkpoint(path, opts)
    pairs = opts.dims // 2
    plain = [(lv, p) for lv in range(opts.levels) for p in range(pairs) if not opts.is_joint(p)]
    if progress is not None:
        progress(
            opts.iterations
            * sum(int(state["stage"][lv, p]) for lv in range(opts.levels) for p in range(pairs))
        )
    for stage in range(opts.levels):
        todo = [
            _Job(opts, lv, p) for lv, p in plain if lv >= stage and state["stage"][lv, p] == stage
        ]
        if not todo:
            continue
        if not _run_round(opts, state, todo, stage, (progress, deadline)):
            return state["scramble"], state["rank"], False
        if path is not None:
            _save_checkpoint(path, opts, state)
    for level in range(opts.levels):
        for pair in range(1, pairs) if opts.joint else ():
            if state["stage"][level, pair] or (
                deadline is not None and time.monotonic() > deadline
            ):
                continue
            job = _Job(opts, level, pair)
            keys, rank = _run_joint(job, state, progress)
            _store(state, job, keys, rank)
            state["stage"][level, pair] = 1
            if path is not None:
                _save_checkpoint(path, opts, state)
    done = all(
        state["stage"][lv, p] == opts.stages(lv, p)
        for lv in range(opts.levels)
        for p in range(pairs)
    )
    return state["scramble"], state["rank"], done


def optimize_keys(
    opts: KeyOptions,
    checkpoint: str | Path | None = None,
    progress: Callable[[int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Optimize every level's scrambling and ranking keys (module docstring).

    Args:
        opts: what to optimize for.
        checkpoint: an ``.npz`` file to resume from and to write after each round (None: none).
        progress: called with the number of descent iterations just done (summed over jobs).

    Returns:
        ``(scramble [L, F, T, T, D], rank [L, F, T, T, D // 2])`` int32.

    Raises:
        FileFormatError: the checkpoint was written for other options.
    """
    scramble, rank, _ = run_keys(opts, checkpoint, progress)
    return scramble, rank


def ldbn_file_name(kind: str, size: int, frames: int = 1) -> str:
    """The shipped file of a key set: ``ldbn_<kind>_<T>.npy`` or ``ldbn_<kind>_<T>x<F>.npy``."""
    return f"ldbn_{kind}_{size}.npy" if frames == 1 else f"ldbn_{kind}_{size}x{frames}.npy"


def write_keys(path: str | Path, scramble: np.ndarray, rank: np.ndarray) -> None:
    """Write one key set as int32 ``[L, F, T, T, D + D // 2]`` (scrambling keys, then ranks)."""
    with atomic_write(Path(path)) as tmp:
        np.save(tmp, np.concatenate([scramble, rank], -1).astype(np.int32), allow_pickle=False)


def shipped_ldbn() -> list[str]:
    """The shipped key sets' kinds and sizes as file names (``ldbn_*.npy``)."""
    return shipped_files("ldbn_")


#: Key set kinds over a base other than ``sobol`` (file ``ldbn_<kind>_<T>.npy``) -> the base.
KIND_BASES = {"lattice": "lattice", "zorder": "zorder"}


def load_ldbn_keys(
    kind: str,
    size: int,
    frames: int = 1,
    levels: int | None = None,
    dims: int | None = None,
    seed0: int = SHIPPED_SEED0,
) -> list[LDBNKeys]:
    """The shipped key set ``kind`` (``screen``, ``st``, ``fast``, ``atrous``, or ``lattice``
    and ``zorder`` over those bases, :data:`KIND_BASES`) of tile ``size`` and ``frames``
    slices, one :class:`LDBNKeys` per frame slice (one for a screen tile).

    The levels L and dimensions D are read from the file's shape ``[L, F, T, T, D + D/2]``;
    ``levels`` or ``dims``, when given, must match. Raises FileFormatError if the file is absent
    or malformed."""
    shape = (levels, frames, size, size, None if dims is None else dims + dims // 2)
    array = load_array(ldbn_file_name(kind, size, frames), np.int32, shape)
    base = KIND_BASES.get(kind, "sobol")
    return keys_from_array(array, ldbn_file_name(kind, size, frames), seed0, base)


def keys_from_array(
    array: np.ndarray, name: str, seed0: int = SHIPPED_SEED0, base: str = "sobol"
) -> list[LDBNKeys]:
    """One :class:`LDBNKeys` per frame slice of a key table ``[L, F, T, T, D + D/2]`` (as
    :func:`write_keys` writes it; D read from the channels) over ``base``, ``name`` naming it
    in errors."""
    if array.ndim != 5:
        raise FileFormatError(
            f"{name}: expected keys [L, F, T, T, D + D/2], got {list(array.shape)}"
        )
    channels = array.shape[-1]
    if channels % 3 or channels < 3:
        raise FileFormatError(f"{name}: expected D + D/2 channels for an even D, got {channels}")
    keys = torch.from_numpy(np.ascontiguousarray(array, dtype=np.int32))
    dims = 2 * channels // 3
    return [
        LDBNKeys(
            keys[:, f, ..., :dims].contiguous(), keys[:, f, ..., dims:].contiguous(), seed0, base
        )
        for f in range(keys.shape[1])
    ]

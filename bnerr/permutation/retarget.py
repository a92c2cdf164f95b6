"""The retargeting pass of Heitz & Belcour 2019: a precomputed local permutation of the seed image.

Heitz & Belcour, "Distributing Monte Carlo Errors as a Blue Noise in Screen Space by Permuting
Pixel Seeds Between Frames", EGSR 2019, section 5 (the retargeting pass); docs/METHODS.md,
section 4.

After the sorting pass of frame t, the seed at pixel p is ranked like the mask value
``M(p + o_t)`` (``o_t`` the frame's toroidal offset). Frame t + 1 uses the mask shifted by the
constant R2 step ``s`` (:func:`bnerr.masks.r2_step`), so the seeds must move to where the next
frame's mask wants their rank: pixel p takes the seed of pixel ``p + d(q)``, ``q = (p + o_t) mod
T``, where the displacement field ``d`` (at most :data:`MAX_DISPLACEMENT` = 6 pixels in x and y)
is chosen once per mask to minimize

    ``E(d) = mean_q |M(q + d(q)) - M(q + s)|``

over displacement fields whose map ``q -> q + d(q) (mod T)`` is a permutation of the tile. The
seed moved to p then carries the old mask value ``M(q + d(q))``, close to the new one
``M(q + s)``. Seeds cross block boundaries this way, which the sorting pass alone never does.

- :func:`optimize_retarget`: the optimizer. ``method="anneal"`` is the paper's simulated
  annealing over pair swaps (many disjoint swaps per step, vectorized in numpy); ``method="exact"``
  solves the same problem exactly as a sparse minimum-cost bipartite matching (scipy's LAPJVsp,
  ``scipy.sparse.csgraph.min_weight_full_bipartite_matching``): every target pixel has 169
  candidate sources, and the optimum is about 40% lower in energy than annealing reaches. The
  shipped permutations (``bnerr/data/retarget_<T>.npy``, made by ``bnerr retarget``) are exact.
- :func:`retarget` / :class:`Retarget`: apply a displacement field to a seed image at a frame's
  offset. The lift of a tile permutation to the infinite plane is a bijection; on a finite
  screen the few targets near the border whose source lies outside the screen take the seeds
  that no target claimed (both sets ordered row-major and paired in order), so the result is
  always a permutation of the input seeds. Those border pixels lose what earlier frames learned.
  The gather is the torch custom op ``torch.ops.bnerr.retarget(seeds, displacement, inverse,
  oy, ox)`` (with a fake implementation, so it composes with ``torch.compile``), dispatched by
  device: on the CPU the optional C kernel of :mod:`bnerr.native` (a source is unclaimed iff its
  preimage under :func:`inverse_field` is off screen), checked once against the torch path before
  it is trusted; elsewhere torch gather indices (:func:`retarget_sources`). Both give identical
  results.
- :func:`load_retarget`: the shipped displacement field for the shipped scalar mask of size T.

**With the options of docs/METHODS.md, section 8.** The field lives in mask space, not in the
sorting pass's blocks: pass frame t's *mask* offset ``o_t`` (the one the sorted mask was tiled
at), whatever block-grid offset (``sort_pass(..., grid_offset=g_t)``) or groups the sorting pass
used. After a sort, the seed at p is ranked like ``M(p + o_t)`` among its block's (or group's)
pixels, however the blocks were cut, and the field moves it to where ``M(. + o_t + s)`` wants
that rank; the grid offset only changes which seeds competed. Reprojection along motion
(:func:`bnerr.permutation.reproject.reproject_seeds`) comes after this pass, carrying the retargeted
seed image from frame t's screen to frame t + 1's.

Not for: masks other than the one a field was optimized for (run :func:`optimize_retarget` on
yours), or a step that changes between frames.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from bnerr import native
from bnerr.errors import (
    FLOAT_DTYPES,
    INT_DTYPES,
    DtypeError,
    FileFormatError,
    ShapeError,
    UnknownNameError,
    ValueRangeError,
    check_dtype,
    check_finite,
    check_name,
    check_offset,
    check_positive_int,
    check_range,
    check_shape,
    check_tensor,
)
from bnerr.io import atomic_write
from bnerr.masks import r2_step
from bnerr.resources import data_dir, load_array, shipped_files
from bnerr.tensor_memo import TensorMemo

__all__ = [
    "MAX_DISPLACEMENT",
    "METHODS",
    "Retarget",
    "check_displacement",
    "inverse_field",
    "load_retarget",
    "read_shipped_field",
    "optimize_retarget",
    "retarget",
    "retarget_energy",
    "retarget_sources",
    "save_retarget",
    "shipped_retargets",
]

#: Largest displacement of a seed per frame, in pixels along x and along y (the paper's 6).
MAX_DISPLACEMENT = 6
#: Optimizer methods of :func:`optimize_retarget`.
METHODS: tuple[str, ...] = ("anneal", "exact")


# --------------------------------------------------------------------------------------------------
# Checks


def _check_tile_mask(mask: object) -> np.ndarray:
    """A ``[T, T]`` floating, finite mask as a float64 numpy array."""
    mask = check_tensor(mask, "mask")
    size = check_shape(mask, "T T", "mask")
    check_dtype(mask, FLOAT_DTYPES, "mask")
    check_finite(mask, "mask")
    if size["T"] < 1:
        raise ShapeError(f"mask: expected a non-empty [T, T] tile, got shape {list(mask.shape)}")
    return mask.detach().to("cpu", torch.float64).numpy()


def _check_step(step: object, size: int) -> tuple[int, int]:
    if step is None:
        return r2_step(size)
    if (
        not isinstance(step, (tuple, list))
        or len(step) != 2
        or any(isinstance(s, bool) or not isinstance(s, int) for s in step)
    ):
        raise DtypeError(f"step: expected a pair of integers (dy, dx), got {step!r}")
    return step[0] % size, step[1] % size


def check_displacement(displacement: object, radius: int | None = MAX_DISPLACEMENT) -> torch.Tensor:
    """Check a displacement field and return it as int64.

    Args:
        displacement: ``[2, T, T]`` integer tensor ``(dy, dx)``: target q takes the seed of
            ``q + d(q)``.
        radius: the largest allowed ``|dy|`` and ``|dx|``, or None for no bound (any field whose
            map is a permutation of the tile lifts to a bijection of the screen).

    Returns:
        ``displacement`` as int64 on its device.

    Raises:
        ShapeError (not ``[2, T, T]``), DtypeError (not integer), ValueRangeError (a component
        beyond ``radius``, or two targets taking the same source: not a permutation of the tile).
    """
    displacement = check_tensor(displacement, "displacement")
    check_shape(displacement, "2 T T", "displacement")
    check_dtype(displacement, INT_DTYPES, "displacement")
    d = displacement.to(torch.int64)
    size = d.shape[-1]
    if size == 0:
        raise ShapeError("displacement: expected a non-empty [2, T, T] field, got T = 0")
    largest = int(d.abs().max())
    if radius is not None and largest > radius:
        raise ValueRangeError(f"displacement: expected |dy|, |dx| <= {radius}, got {largest}")
    q = torch.arange(size, device=d.device)
    src = ((q[:, None] + d[0]) % size) * size + (q[None, :] + d[1]) % size
    hits = torch.bincount(src.reshape(-1), minlength=size * size)
    if bool((hits != 1).any()):
        raise ValueRangeError(
            f"displacement: expected a permutation of the {size}x{size} tile, got "
            f"{int((hits == 0).sum())} sources never taken and {int((hits > 1).sum())} taken twice"
        )
    return d


# --------------------------------------------------------------------------------------------------
# Energy and optimizers


def _grid(size: int) -> tuple[np.ndarray, np.ndarray]:
    y, x = np.divmod(np.arange(size * size), size)
    return y, x


def _energy(m: np.ndarray, dy: np.ndarray, dx: np.ndarray, step: tuple[int, int]) -> float:
    size = m.shape[0]
    y, x = _grid(size)
    src = m[(y + dy.reshape(-1)) % size, (x + dx.reshape(-1)) % size]
    return float(np.abs(src - m[(y + step[0]) % size, (x + step[1]) % size]).mean())


def retarget_energy(
    mask: torch.Tensor, displacement: torch.Tensor, step: tuple[int, int] | None = None
) -> float:
    """``mean_q |M(q + d(q)) - M(q + step)|`` over the tile (float64).

    Args:
        mask: ``[T, T]`` floating, finite scalar mask.
        displacement: ``[2, T, T]`` integer field (checked with :func:`check_displacement`, any
            radius); zeros give the identity's energy, about 1/3 for a blue-noise mask.
        step: ``(dy, dx)``; default :func:`bnerr.masks.r2_step` of T.
    """
    m = _check_tile_mask(mask)
    d = check_displacement(displacement, radius=None).cpu().numpy()
    if d.shape[-1] != m.shape[0]:
        raise ShapeError(
            f"displacement: expected [2, {m.shape[0]}, {m.shape[0]}] like mask, got {list(d.shape)}"
        )
    return _energy(m, d[0], d[1], _check_step(step, m.shape[0]))


def _anneal(
    m: np.ndarray,
    step: tuple[int, int],
    radius: int,
    iterations: int,
    temperature: float,
    seed: int,
) -> tuple[np.ndarray, np.ndarray]:
    """Simulated annealing over pair swaps of sources; returns ``(dy, dx)`` flat int64 arrays.

    Each iteration draws one offset ``v`` (``|v| <= radius``) and a random bit per target; every
    target q with bit 1 whose partner ``q + v`` has bit 0 proposes to swap sources with it. The
    pairs are disjoint by construction (a target is a first member only with bit 1, a second only
    with bit 0), so all of them are evaluated and accepted at once (Metropolis, temperature
    falling quadratically to zero). A swap is allowed only if both new displacements stay within
    ``radius``. Energy is the sum of the two targets' terms before and after.
    """
    size = m.shape[0]
    flat = m.reshape(-1)
    y, x = _grid(size)
    target = m[(y + step[0]) % size, (x + step[1]) % size]
    src = np.arange(size * size)
    dy = np.zeros(size * size, np.int64)
    dx = np.zeros(size * size, np.int64)
    rng = np.random.default_rng(seed)
    for it in range(iterations):
        vy, vx = (int(v) for v in rng.integers(-radius, radius + 1, 2))
        bits = rng.random(size * size) < 0.5
        if vy == 0 and vx == 0:
            continue
        partner = ((y + vy) % size) * size + (x + vx) % size
        a = np.flatnonzero(bits & ~bits[partner])
        b = partner[a]
        ay, ax, by, bx = dy[b] + vy, dx[b] + vx, dy[a] - vy, dx[a] - vx
        ok = (
            (np.abs(ay) <= radius)
            & (np.abs(ax) <= radius)
            & (np.abs(by) <= radius)
            & (np.abs(bx) <= radius)
        )
        sa, sb = src[a], src[b]
        delta = (
            np.abs(flat[sb] - target[a])
            + np.abs(flat[sa] - target[b])
            - np.abs(flat[sa] - target[a])
            - np.abs(flat[sb] - target[b])
        )
        temp = temperature * (1.0 - it / iterations) ** 2
        uphill = rng.random(a.size)
        with np.errstate(over="ignore"):
            accept = ok & ((delta < 0) | (uphill < np.exp(-delta / max(temp, 1e-300))))
        a, b = a[accept], b[accept]
        src[a], src[b] = sb[accept], sa[accept]
        dy[a], dx[a], dy[b], dx[b] = ay[accept], ax[accept], by[accept], bx[accept]
    return dy, dx


def _exact(m: np.ndarray, step: tuple[int, int], radius: int) -> tuple[np.ndarray, np.ndarray]:
    """Minimum-cost perfect matching of targets to sources within ``radius`` (scipy LAPJVsp)."""
    try:
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import min_weight_full_bipartite_matching
    except ImportError as err:  # scipy comes with scikit-image, a bnerr dependency
        raise UnknownNameError(
            "method: 'exact' needs scipy (pip install scipy); use method='anneal' without it"
        ) from err
    size = m.shape[0]
    flat = m.reshape(-1)
    y, x = _grid(size)
    target = m[(y + step[0]) % size, (x + step[1]) % size]
    offsets = [(oy, ox) for oy in range(-radius, radius + 1) for ox in range(-radius, radius + 1)]
    # Distinct offsets can alias on a small torus; keep the first, so every edge is one source.
    offsets = list({((oy % size), (ox % size)): (oy, ox) for oy, ox in offsets}.values())
    oy = np.array([o[0] for o in offsets])
    ox = np.array([o[1] for o in offsets])
    sources = ((y[:, None] + oy) % size) * size + (x[:, None] + ox) % size  # [N, K]
    # +1 on every edge: explicit zeros would be dropped from the sparse graph, and a constant per
    # target does not move the optimum (every target has exactly one edge in a perfect matching).
    cost = np.abs(flat[sources] - target[:, None]) + 1.0
    rows = np.repeat(np.arange(size * size), len(offsets))
    graph = csr_matrix((cost.reshape(-1), (rows, sources.reshape(-1))), shape=(size * size,) * 2)
    matched_rows, matched_cols = min_weight_full_bipartite_matching(graph)
    choice = np.empty(size * size, np.int64)
    choice[matched_rows] = matched_cols
    # Recover which offset each target took (its source determines it uniquely).
    pick = np.argmax(sources == choice[:, None], axis=1)
    return oy[pick].astype(np.int64), ox[pick].astype(np.int64)


def optimize_retarget(
    mask: torch.Tensor,
    step: tuple[int, int] | None = None,
    *,
    method: str = "anneal",
    radius: int = MAX_DISPLACEMENT,
    iterations: int = 40000,
    temperature: float = 0.05,
    seed: int = 0,
) -> torch.Tensor:
    """Optimize the retargeting displacement field of a scalar mask (see the module docstring).

    Args:
        mask: ``[T, T]`` floating, finite scalar mask (the one the sorting pass uses).
        step: the per-frame toroidal step ``(dy, dx)``; default :func:`bnerr.masks.r2_step`.
        method: ``"anneal"`` (simulated annealing, the paper's method, numpy only) or ``"exact"``
            (optimal sparse assignment, needs scipy).
        radius: largest ``|dy|``, ``|dx|`` (default 6, the paper's).
        iterations: annealing steps (each proposes about T^2 / 4 disjoint swaps); ignored by
            ``"exact"``. 40000 take about 10 s at T = 64.
        temperature: initial annealing temperature in energy units (a swap that raises the energy
            by this much is accepted with probability 1/e at the start); ignored by ``"exact"``.
        seed: seed of the annealing's numpy generator (same numpy version and seed, same result).

    Returns:
        ``[2, T, T]`` int64 displacement ``(dy, dx)`` on the CPU; a permutation of the tile with
        every component in ``[-radius, radius]``.
    """
    m = _check_tile_mask(mask)
    step = _check_step(step, m.shape[0])
    method = check_name(method, METHODS, "retarget method")
    radius = check_positive_int(radius, "radius", minimum=0)
    if method == "exact":
        dy, dx = _exact(m, step, radius)
    else:
        iterations = check_positive_int(iterations, "iterations", minimum=0)
        temperature = check_range(temperature, "temperature", 0.0, 1.0)
        seed = check_positive_int(seed, "seed", minimum=0)
        dy, dx = _anneal(m, step, radius, iterations, float(temperature), seed)
    size = m.shape[0]
    return torch.from_numpy(np.stack([dy, dx]).reshape(2, size, size).copy())


# --------------------------------------------------------------------------------------------------
# Shipped fields


def shipped_retargets() -> list[int]:
    """Tile sizes T with a shipped ``retarget_<T>.npy``, sorted."""
    stems = (
        name.removeprefix("retarget_").removesuffix(".npy") for name in shipped_files("retarget_")
    )
    return sorted(int(stem) for stem in stems if stem.isdigit())


def load_retarget(size: int) -> torch.Tensor:
    """The shipped displacement field for the shipped scalar mask ``load_mask("scalar", size)``.

    Returns:
        ``[2, T, T]`` int64 on the CPU, checked (a permutation, ``|d| <= 6``).

    Raises:
        UnknownNameError: no field of that size is shipped (the message lists the shipped sizes).
        FileFormatError: the file is unreadable or not a valid field.
    """
    size = check_positive_int(size, "size")
    shipped = shipped_retargets()
    if size not in shipped:
        raise UnknownNameError(
            f"retarget size {size}: expected one of the shipped sizes {shipped or 'none shipped'}"
        )
    return read_shipped_field(f"retarget_{size}.npy", size)


def read_shipped_field(name: str, size: int) -> torch.Tensor:
    """A shipped displacement field ``name`` (int8 ``[2, size, size]`` in the package data),
    checked: ``[2, T, T]`` int64 on the CPU.

    Raises:
        FileFormatError: the file is missing, unreadable or not a valid field.
    """
    array = load_array(name, np.int8, (2, size, size))
    try:
        return check_displacement(torch.from_numpy(array.astype(np.int64)))
    except ValueError as err:
        raise FileFormatError(
            f"{data_dir().joinpath(name)}: expected a valid displacement field, got: {err}"
        ) from err


def save_retarget(path: str | Path, displacement: torch.Tensor) -> None:
    """Write a checked field as an int8 ``[2, T, T]`` ``.npy`` file, atomically."""
    d = check_displacement(displacement, radius=127).cpu().numpy().astype(np.int8)
    with atomic_write(path) as tmp:
        np.save(tmp, d, allow_pickle=False)


# --------------------------------------------------------------------------------------------------
# Applying a field to a seed image


def _band(height: int, width: int, margin: int, device: torch.device) -> torch.Tensor:
    """Flat indices, row-major, of the pixels within ``margin`` of the screen's border."""
    if height <= 2 * margin or width <= 2 * margin:
        return torch.arange(height * width, device=device)
    xs = torch.arange(width, device=device)
    top = torch.arange(margin * width, device=device)
    strips = torch.cat([xs[:margin], xs[width - margin :]])
    middle = (
        torch.arange(margin, height - margin, device=device)[:, None] * width + strips
    ).reshape(-1)
    return torch.cat([top, middle, top + (height - margin) * width])


def _border_pairs(
    height: int, width: int, displacement: torch.Tensor, offset: tuple[int, int]
) -> tuple[torch.Tensor, torch.Tensor] | None:
    """``(lost, free)``: flat indices of the targets whose source is off screen and of the sources
    no target claims, both row-major and equally many; None when every source is on screen.

    Only targets within ``reach`` (the largest displacement) of the border can point outside, only
    sources within ``reach`` of it can go unclaimed, and those can only be claimed by targets within
    ``2 * reach``; so only that band is examined.
    """
    size = displacement.shape[-1]
    device = displacement.device
    oy, ox = offset[0] % size, offset[1] % size
    reach = int(displacement.abs().max()) if displacement.numel() else 0
    if reach == 0:
        return None
    targets = _band(height, width, 2 * reach, device)
    ty, tx = targets // width, targets % width
    qy, qx = (ty + oy) % size, (tx + ox) % size
    sy, sx = ty + displacement[0, qy, qx], tx + displacement[1, qy, qx]
    inside = (sy >= 0) & (sy < height) & (sx >= 0) & (sx < width)
    if bool(inside.all()):
        return None
    pool = _band(height, width, reach, device)
    taken = sy[inside] * width + sx[inside]
    pos = torch.searchsorted(pool, taken).clamp_(max=pool.numel() - 1)
    claimed = torch.zeros(pool.numel(), dtype=torch.bool, device=device)
    claimed[pos[pool[pos] == taken]] = True
    free = pool[~claimed]
    lost = targets[~inside]
    # The lift of a tile permutation is a bijection of the plane, so the in-screen sources are
    # distinct and exactly as many sources go unclaimed as targets point outside.
    if free.numel() != lost.numel():
        raise ValueRangeError(
            "displacement: expected a permutation of the tile (as many free seeds as targets "
            f"outside the screen), got {lost.numel()} targets outside but {free.numel()} free seeds"
        )
    return lost, free


def retarget_sources(
    height: int, width: int, displacement: torch.Tensor, offset: tuple[int, int]
) -> torch.Tensor:
    """Gather indices of the retargeting permutation on an ``H x W`` screen.

    Pixel ``p = (y, x)`` takes the seed of ``p + d(q)``, ``q = ((y + oy) mod T, (x + ox) mod T)``;
    targets whose source falls outside the screen take, in row-major order, the sources no target
    claimed, in row-major order (see the module docstring).

    Args:
        height, width: H, W >= 1.
        displacement: ``[2, T, T]`` int64 checked field (not re-checked here), on the output
            device.
        offset: the frame's toroidal offset ``(oy, ox)`` (``frame_offset(t, T)``).

    Returns:
        ``[H * W]`` int32 (int64 for images of 2^31 pixels or more), a permutation of
        ``0 .. H*W - 1``: ``new.view(-1) = old.view(-1).index_select(0, src)``.
    """
    size = displacement.shape[-1]
    device = displacement.device
    oy, ox = offset[0] % size, offset[1] % size
    reach = int(displacement.abs().max()) if displacement.numel() else 0
    # int32 indices where they fit: half the memory traffic of int64 in this memory-bound pass.
    index = torch.int32 if (height + reach) * (width + reach) < 2**31 else torch.int64
    # Interior: the flat index offset dy * W + dx, tiled like the mask (roll + repeat are copies,
    # much cheaper than a per-pixel gather from the tile).
    tile = (displacement[0] * width + displacement[1]).to(index).roll((-oy, -ox), dims=(0, 1))
    field = tile.repeat(-(-height // size), -(-width // size))[:height, :width]
    src = (
        torch.arange(height * width, dtype=index, device=device)
        .view(height, width)
        .add_(field)
        .reshape(-1)
    )
    pairs = _border_pairs(height, width, displacement, offset)
    if pairs is not None:
        src[pairs[0]] = pairs[1].to(index)
    return src


def inverse_field(displacement: torch.Tensor) -> torch.Tensor:
    """The inverse of a checked field: at tile position u, the displacement ``e(u) = -d(q)`` back
    to the target q that takes the source at u (``q + d(q) = u mod T``). ``[2, T, T]`` int64."""
    size = displacement.shape[-1]
    q = torch.arange(size, device=displacement.device)
    src = (
        ((q[:, None] + displacement[0]) % size) * size + (q[None, :] + displacement[1]) % size
    ).reshape(-1)
    owner = torch.empty_like(src)
    owner[src] = torch.arange(size * size, device=displacement.device)
    return -displacement.reshape(2, -1)[:, owner].reshape(2, size, size)


def _gather_torch(
    seeds: torch.Tensor, displacement: torch.Tensor, oy: int, ox: int
) -> torch.Tensor:
    """The torch path: gather through :func:`retarget_sources`' indices."""
    h, w = seeds.shape
    src = retarget_sources(h, w, displacement, (oy, ox))
    return seeds.reshape(-1).index_select(0, src).reshape(h, w)


def _self_check(kernels: native.Kernels) -> bool:
    """Compare the native gather with the torch path on a small odd-sized screen with a random
    field (border pairs included): True if bit-identical."""
    gen = torch.Generator().manual_seed(1234)
    mask = torch.rand(16, 16, generator=gen)
    field = optimize_retarget(mask, (3, 5), iterations=40, temperature=1.0)
    seeds = torch.randperm(37 * 29, generator=gen).view(37, 29)
    for offset in ((4, 9), (0, 0), (15, 1)):
        want = _gather_torch(seeds, field, *offset)
        form = native.retarget_field(field, inverse_field(field))
        got = native.native_retarget_gather(kernels, seeds, form, offset)
        if got is None or not torch.equal(got, want):
            return False
    return True


#: The native kernels if they load and pass :func:`_self_check` (run once per library).
_native_kernels = native.SelfCheckedKernels(
    _self_check, "bnerr.permutation.retarget: the native retargeting kernel"
)


# The op, registered with the low-level torch.library API (a few microseconds of dispatch per
# call, where torch.library.custom_op's Python wrappers cost about 30).
_LIBRARY = torch.library.Library("bnerr", "FRAGMENT")
_LIBRARY.define(
    "retarget(Tensor seeds, Tensor displacement, Tensor? inverse, int oy, int ox) -> Tensor"
)


def _retarget_default(
    seeds: torch.Tensor,
    displacement: torch.Tensor,
    inverse: torch.Tensor | None,
    oy: int,
    ox: int,
) -> torch.Tensor:
    """``torch.ops.bnerr.retarget(seeds, displacement, inverse, oy, ox)``: the retargeting pass.

    ``seeds [H, W]`` int64; ``displacement [2, T, T]`` int64, a checked field on ``seeds``'
    device; ``inverse`` its :func:`inverse_field` or None (computed where needed); returns
    ``[H, W]`` int64. Inputs are not checked here (:func:`retarget` checks them). This default
    kernel (CUDA and every other device but the CPU) is the torch path.
    """
    return _gather_torch(seeds, displacement, oy, ox)


def _retarget_cpu(
    seeds: torch.Tensor,
    displacement: torch.Tensor,
    inverse: torch.Tensor | None,
    oy: int,
    ox: int,
) -> torch.Tensor:
    """CPU kernel of the op: the native kernel where it loads and passed its check, else torch.

    The field's kernel form (int32 copies of it and of its inverse, its reach) is made once per
    field tensor (:data:`_NATIVE_FIELDS`), not every frame.
    """
    kernels = _native_kernels()
    if kernels is not None:
        form = _NATIVE_FIELDS.get(
            displacement, "native", lambda: _native_field(displacement, inverse)
        )
        threads = torch.get_num_threads() if seeds.numel() >= 1 << 16 else 1
        out = native.native_retarget_gather(kernels, seeds, form, (oy, ox), threads)
        if out is not None:
            return out
    return _gather_torch(seeds, displacement, oy, ox)


def _native_field(displacement: torch.Tensor, inverse: torch.Tensor | None) -> native.RetargetField:
    back = inverse_field(displacement) if inverse is None else inverse
    return native.retarget_field(displacement, back)


#: The native kernel's form of the fields the op was given, keyed by the field tensor. A field's
#: inverse is determined by the field, so the form does not depend on whether the caller passed it.
_NATIVE_FIELDS: TensorMemo[native.RetargetField] = TensorMemo()
#: A :class:`Retarget`'s field and its inverse on a device, keyed by its buffer and the device.
_DEVICE_FIELDS: TensorMemo[tuple[torch.Tensor, torch.Tensor]] = TensorMemo()


@torch.library.register_fake("bnerr::retarget")
def _retarget_fake(
    seeds: torch.Tensor,
    displacement: torch.Tensor,
    inverse: torch.Tensor | None,
    oy: int,
    ox: int,
) -> torch.Tensor:
    """Shape propagation for ``torch.compile``: the output is like ``seeds``."""
    return torch.empty_like(seeds, memory_format=torch.contiguous_format)


_LIBRARY.impl("retarget", _retarget_cpu, "CPU")
_LIBRARY.impl("retarget", _retarget_default, "CompositeExplicitAutograd")


def _check_seeds(seeds: object) -> tuple[int, int]:
    """``(H, W)`` of a seed image: an ``[H, W]`` int64 tensor."""
    tensor = check_tensor(seeds, "seeds")
    size = check_shape(tensor, "H W", "seeds")
    check_dtype(tensor, torch.int64, "seeds")
    return size["H"], size["W"]


def _on_device(
    displacement: torch.Tensor, device: torch.device
) -> tuple[torch.Tensor, torch.Tensor]:
    """A checked field on ``device`` (the tensor itself where it is already there) and its
    inverse."""
    field = displacement.to(device)
    return field, inverse_field(field)


def retarget(
    seeds: torch.Tensor, displacement: torch.Tensor, offset: tuple[int, int]
) -> torch.Tensor:
    """Apply a retargeting field to a seed image at a frame's offset.

    Args:
        seeds: ``[H, W]`` int64 seed image (after the sorting pass of frame t).
        displacement: ``[2, T, T]`` integer field (:func:`load_retarget`,
            :func:`optimize_retarget`); checked here.
        offset: frame t's mask offset ``(oy, ox)``: the field is laid over the screen like the
            mask, ``d((y + oy) mod T, (x + ox) mod T)`` at pixel (y, x).

    Returns:
        ``[H, W]`` int64 on ``seeds``' device: a permutation of ``seeds`` (every seed kept, none
        duplicated), for frame t + 1.
    """
    _check_seeds(seeds)
    offset = check_offset(offset)
    d = check_displacement(displacement, radius=None)
    if seeds.numel() == 0:
        return seeds.clone()
    return torch.ops.bnerr.retarget.default(seeds, d.to(seeds.device), None, offset[0], offset[1])


class Retarget(torch.nn.Module):
    """Module form of :func:`retarget` holding one checked field; ``forward(seeds, offset)``.

    The field is checked once, here; its copy on each device, its inverse and its native kernel
    form are made once (again only if the buffer is replaced or edited in place). Where the
    gather runs in torch (no native kernel, or not on the CPU), the gather indices of the last
    ``cache`` (screen size, offset, device) combinations are kept, so that a loop whose offsets
    cycle (16 distinct ones for T = 64) computes each only once. Each entry holds ``H * W`` int32
    (8 MB at 1080p); ``cache=0`` keeps none.
    """

    displacement: torch.Tensor  # a buffer: ``[2, T, T]`` int64

    def __init__(self, displacement: torch.Tensor, cache: int = 0) -> None:
        super().__init__()
        self.register_buffer("displacement", check_displacement(displacement, radius=None))
        self.cache = check_positive_int(cache, "cache", minimum=0)
        self._sources: dict[tuple, torch.Tensor] = {}

    def forward(self, seeds: torch.Tensor, offset: tuple[int, int]) -> torch.Tensor:
        """``seeds [H, W]`` int64 -> ``[H, W]`` int64, as :func:`retarget`."""
        _check_seeds(seeds)
        offset = check_offset(offset)
        if seeds.numel() == 0:
            return seeds.clone()
        return self._gather(seeds, offset)

    def _gather(self, seeds: torch.Tensor, offset: tuple[int, int]) -> torch.Tensor:
        """The pass on checked, non-empty seeds: the cached indices on the torch path, else the
        op (which takes the native kernel on the CPU)."""
        device = seeds.device
        field, inverse = _DEVICE_FIELDS.get(
            self.displacement, device, lambda: _on_device(self.displacement, device)
        )
        if self.cache and not (device.type == "cpu" and _native_kernels() is not None):
            height, width = seeds.shape
            src = self._cached_sources(height, width, offset, field)
            return seeds.reshape(-1).index_select(0, src).reshape(height, width)
        return torch.ops.bnerr.retarget.default(seeds, field, inverse, offset[0], offset[1])

    def _cached_sources(
        self, height: int, width: int, offset: tuple[int, int], field: torch.Tensor
    ) -> torch.Tensor:
        """The torch path's gather indices for this screen and offset, from the cache if there."""
        t = field.shape[-1]
        key = (height, width, offset[0] % t, offset[1] % t, field.device)
        src = self._sources.get(key)
        if src is None:
            src = retarget_sources(height, width, field, key[2:4])
            while len(self._sources) >= self.cache:
                self._sources.pop(next(iter(self._sources)))
            self._sources[key] = src
        return src

    def extra_repr(self) -> str:
        t = self.displacement.shape[-1]
        return f"tile={t}x{t}, cache={self.cache}"

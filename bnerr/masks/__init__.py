"""Blue-noise masks: the tiles that decide where each pixel's error lands (docs/METHODS.md,
sections 2, 7 and 8). One module per kind of mask:

- :mod:`bnerr.masks.spatial`: void-and-cluster scalar masks ``[T, T]`` and Georgiev-Fajardo vector
  masks ``[D, T, T]``, the R2 offset of each frame, tiling, and the shipped masks;
- :mod:`bnerr.masks.stbn`: spatiotemporal masks ``[F, T, T]`` / ``[F, D, T, T]`` (Wolfe et al.
  2022), blue in space and along time;
- :mod:`bnerr.masks.fast`: filter-adapted scalar masks (FAST, Donnelly et al. 2024), annealed for
  the denoiser's filter, with the retargeting field made for them.

The names of :mod:`bnerr.masks.spatial` are importable from here, as they were when
``bnerr.masks`` was one module (``from bnerr.masks import load_mask``). ``stbn`` and ``fast`` are
imported by their own paths: :mod:`bnerr.masks.fast` reads its retargeting field through
:mod:`bnerr.permutation.retarget`, which takes the R2 step from here, so loading it here would
make the two families import each other.
"""

from bnerr.masks.spatial import (
    PLASTIC_NUMBER,
    frame_offset,
    load_mask,
    r2_step,
    shipped_masks,
    tile_mask,
    vector_mask,
    vector_mask_energy,
    void_and_cluster,
)

__all__ = [
    "PLASTIC_NUMBER",
    "frame_offset",
    "load_mask",
    "r2_step",
    "shipped_masks",
    "tile_mask",
    "vector_mask",
    "vector_mask_energy",
    "void_and_cluster",
]

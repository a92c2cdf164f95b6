"""The tracer's memory model: the rough peak bytes of rendering one frame, for the checks that
refuse a resolution before anything is allocated (``bnerr render``, ``bnerr train``'s data).

Not for: the strategies' own buffers (:func:`bnerr.strategies.estimate_bytes`) or a command's
files on disk.
"""

from __future__ import annotations

__all__ = ["RENDER_BYTES_PER_PIXEL", "RENDER_FIXED_BYTES", "render_bytes"]

#: Rough peak memory of one frame per pixel: the seeds, the tracer's per-pixel sums and guide
#: buffers, the Frame, and the EXR and PNG writers' copies. Measured at 1024 x 1024 (cornell):
#: 270 B/px at 1 spp, 430 B/px at 4 spp, including the chunks' fixed working set.
RENDER_BYTES_PER_PIXEL = 448
#: The tracer's working set for its chunks of paths, whatever the resolution (rough).
RENDER_FIXED_BYTES = 256 * 2**20


def render_bytes(width: int, height: int) -> int:
    """Rough peak memory of rendering and writing one ``width x height`` frame."""
    return RENDER_FIXED_BYTES + RENDER_BYTES_PER_PIXEL * width * height

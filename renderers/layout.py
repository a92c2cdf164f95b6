"""Which sampler dimension feeds which decision of the path tracer (the dimension layout).

The renderer consumes a fixed number D of dimensions per sample (METHODS.md section 1), so that a
sampler (white, Owen-scrambled Sobol, blue-noise dithered) sees the integrand's true
dimensionality and a seed's values mean the same thing in every pixel. Paths never terminate early
by Russian roulette, so D depends only on the scene: its maximum depth, its number of lights and
whether it has a participating medium.

Depth follows Mitsuba 3's convention: ``max_depth`` is the longest path in segments, so
``max_depth = 1`` would show only directly visible emitters and ``max_depth = 2`` is direct lighting.
A path has ``B = max_depth - 1`` scattering vertices, numbered ``k = 0 .. B-1`` (vertex 0 is the
camera ray's first hit). The layout, dimension by dimension::

    0, 1                 pixel jitter (x, y) inside the pixel (box filter)
    then for each vertex k = 0 .. B-1, in order:
      [1 if medium]      free-flight distance on the segment that ends at vertex k
      [1 if > 1 light]   which light next-event estimation samples (uniform choice)
      2                  position on that light (u, v of the rectangle)
      2 (not at k=B-1)   direction of the next segment: cosine-weighted BSDF sample on a
                         surface, uniform sphere sample of the isotropic phase function in the
                         medium

The last vertex samples no direction: a path of ``max_depth`` segments can only close through
next-event estimation, so its light sample carries the full weight and the direction sample would
be wasted work (and a wasted dimension). Earlier vertices combine the light sample and the
direction sample by multiple importance sampling. So ``direct`` (one light, depth 2, no medium) has
``D = 2 + 2 = 4``: pixel jitter and one light sample, the case where dithered sampling shines.

Not for: scenes with Russian roulette or adaptive path lengths, whose D is not fixed.
"""

from __future__ import annotations

from dataclasses import dataclass

from bnerr.errors import check_positive_int

__all__ = ["Layout"]


@dataclass(frozen=True)
class Layout:
    """Offsets of every decision in the sample vector of one path.

    Attributes:
        max_depth: longest path in segments (Mitsuba's ``max_depth``), >= 2.
        lights: number of area lights (>= 1); a light-choice dimension exists only if > 1.
        medium: whether a participating medium exists (adds a distance dimension per vertex).
    """

    max_depth: int
    lights: int = 1
    medium: bool = False

    def __post_init__(self) -> None:
        check_positive_int(self.max_depth, "max_depth", minimum=2)
        check_positive_int(self.lights, "lights", minimum=1)

    @property
    def vertices(self) -> int:
        """Number of scattering vertices ``B = max_depth - 1``."""
        return self.max_depth - 1

    @property
    def pixel(self) -> int:
        """First of the two pixel-jitter dimensions (always 0)."""
        return 0

    @property
    def _light_dims(self) -> int:
        return (1 if self.lights > 1 else 0) + 2

    @property
    def _stride(self) -> int:
        """Dimensions of a vertex that also samples a direction."""
        return (1 if self.medium else 0) + self._light_dims + 2

    def vertex(self, k: int) -> int:
        """First dimension of vertex ``k`` (0 <= k < vertices)."""
        return 2 + k * self._stride

    def distance(self, k: int) -> int | None:
        """Free-flight distance dimension of the segment ending at vertex ``k`` (None: no medium)."""
        return self.vertex(k) if self.medium else None

    def light_choice(self, k: int) -> int | None:
        """Light-choice dimension at vertex ``k`` (None when the scene has one light)."""
        if self.lights == 1:
            return None
        return self.vertex(k) + (1 if self.medium else 0)

    def light(self, k: int) -> int:
        """First of the two light-position dimensions at vertex ``k``."""
        return self.vertex(k) + (1 if self.medium else 0) + (1 if self.lights > 1 else 0)

    def direction(self, k: int) -> int | None:
        """First of the two direction dimensions at vertex ``k`` (None at the last vertex)."""
        if k == self.vertices - 1:
            return None
        return self.light(k) + 2

    @property
    def dimensions(self) -> int:
        """D, the number of dimensions one path consumes."""
        last = (1 if self.medium else 0) + self._light_dims
        return 2 + (self.vertices - 1) * self._stride + last

    def describe(self) -> list[str]:
        """One line per dimension saying what it feeds, for ``bnerr scenes`` and docs."""
        lines = ["0: pixel jitter x", "1: pixel jitter y"]
        for k in range(self.vertices):
            d = self.distance(k)
            if d is not None:
                lines.append(f"{d}: vertex {k} free-flight distance")
            c = self.light_choice(k)
            if c is not None:
                lines.append(f"{c}: vertex {k} light choice")
            lo = self.light(k)
            lines += [f"{lo}: vertex {k} light u", f"{lo + 1}: vertex {k} light v"]
            w = self.direction(k)
            if w is not None:
                lines += [f"{w}: vertex {k} direction u", f"{w + 1}: vertex {k} direction v"]
        return lines

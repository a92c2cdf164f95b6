"""Which sampler dimension feeds which decision of the path tracer (the dimension layout).

The renderer consumes a fixed number D of dimensions per sample (docs/METHODS.md, section 1), so
that a sampler (white, Owen-scrambled Sobol, blue-noise dithered) sees the integrand's true
dimensionality and a seed's values mean the same thing in every pixel. Paths never terminate early
by Russian roulette, so D depends only on the scene: its maximum depth, its number of lights and
whether it has a participating medium.

Depth follows Mitsuba 3's convention: ``max_depth`` is the longest path in segments, so
``max_depth = 1`` would show only directly visible emitters and ``max_depth = 2`` is direct
lighting.
A path has ``B = max_depth - 1`` scattering vertices, numbered ``k = 0 .. B-1`` (vertex 0 is the
camera ray's first hit). The layout, dimension by dimension::

    0, 1                 pixel jitter (x, y) inside the pixel (box filter)
    then for each vertex k = 0 .. B-1, in order:
      2                  position on the light that next-event estimation samples (u, v)
      2 (not at k=B-1)   direction of the next segment: cosine-weighted BSDF sample on a
                         surface, uniform sphere sample of the isotropic phase function in the
                         medium
      at even k only:    the one-dimensional decisions of vertices k and k+1, in the order
                         [distance k, choice k, distance k+1, choice k+1], those that exist:
                         "distance j" is the free-flight distance on the segment ending at
                         vertex j (medium scenes), "choice j" the uniform choice of the light
                         vertex j samples (scenes with several lights)

Every 2D decision starts at an even dimension, so it receives a (dim 2j, dim 2j+1) pair: the
pairs that Owen-scrambled Sobol makes (0, m, 2)-nets (bnerr.sequences pads by 2D pairs).
Bundling the 1D decisions of two vertices keeps that alignment without unused dimensions.

The last vertex samples no direction: a path of ``max_depth`` segments can only close through
next-event estimation, so its light sample carries the full weight and the direction sample would
be wasted work (and a wasted dimension). Earlier vertices combine the light sample and the
direction sample by multiple importance sampling. So ``direct`` (one light, depth 2, no medium) has
``D = 2 + 2 = 4``: pixel jitter and one light sample, the case where dithered sampling shines;
``cornell`` (depth 6) has ``2 + 5 * 2 + 4 * 2 = 20``.

Not for: scenes with Russian roulette or adaptive path lengths, whose D is not fixed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from bnerr.errors import check_positive_int

__all__ = ["Layout"]


#: Layout's offsets: light, direction, distance and light-choice dimension per vertex, and D.
_Table = tuple[
    tuple[int, ...], tuple[int | None, ...], tuple[int | None, ...], tuple[int | None, ...], int
]


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
    _table: _Table = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        check_positive_int(self.max_depth, "max_depth", minimum=2)
        check_positive_int(self.lights, "lights", minimum=1)
        vertices = self.max_depth - 1
        light: list[int] = [0] * vertices
        direction: list[int | None] = [None] * vertices
        distance: list[int | None] = [None] * vertices
        choice: list[int | None] = [None] * vertices
        d = 2
        for k in range(vertices):
            light[k], d = d, d + 2
            if k < vertices - 1:
                direction[k], d = d, d + 2
            if k % 2 == 0:
                for j in (k, k + 1):
                    if j < vertices and self.medium:
                        distance[j], d = d, d + 1
                    if j < vertices and self.lights > 1:
                        choice[j], d = d, d + 1
        table = (tuple(light), tuple(direction), tuple(distance), tuple(choice), d)
        object.__setattr__(self, "_table", table)

    @property
    def vertices(self) -> int:
        """Number of scattering vertices ``B = max_depth - 1``."""
        return self.max_depth - 1

    @property
    def pixel(self) -> int:
        """First of the two pixel-jitter dimensions (always 0)."""
        return 0

    def light(self, k: int) -> int:
        """First of the two light-position dimensions at vertex ``k``."""
        return self._table[0][k]

    def direction(self, k: int) -> int | None:
        """First of the two direction dimensions at vertex ``k`` (None at the last vertex)."""
        return self._table[1][k]

    def distance(self, k: int) -> int | None:
        """Dimension of the free-flight distance sampled before vertex ``k`` (None: no medium)."""
        return self._table[2][k]

    def light_choice(self, k: int) -> int | None:
        """Light-choice dimension at vertex ``k`` (None when the scene has one light)."""
        return self._table[3][k]

    @property
    def dimensions(self) -> int:
        """D, the number of dimensions one path consumes."""
        return self._table[4]

    def describe(self) -> list[str]:
        """One line per dimension, in order, saying what it feeds (for ``bnerr scenes``)."""
        names = {0: "pixel jitter x", 1: "pixel jitter y"}
        for k in range(self.vertices):
            names[self.light(k)] = f"vertex {k} light u"
            names[self.light(k) + 1] = f"vertex {k} light v"
            if (direction := self.direction(k)) is not None:
                names[direction] = f"vertex {k} direction u"
                names[direction + 1] = f"vertex {k} direction v"
            if (distance := self.distance(k)) is not None:
                names[distance] = f"vertex {k} free-flight distance"
            if (choice := self.light_choice(k)) is not None:
                names[choice] = f"vertex {k} light choice"
        return [f"{d}: {names[d]}" for d in range(self.dimensions)]

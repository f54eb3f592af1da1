"""Named layout of an error-state vector (thesis §3, eq. 3.5; extraction seed-000 §3.4).

Blocks, always in this order when present: ``p`` (3), ``v`` (3), ``th`` (3, attitude error
delta-theta of eq. 4.8), ``ba`` (3), ``bg`` (3), then scalar first-order Gauss-Markov measurement
biases with names, e.g. ``("b_alt", "b_range", "b_rate")`` (chapter 3, 18 states) or
``("b_alt", "b_range", "b_cross")`` (chapter 5); ``blocks=("p", "v", "th")`` and no scalar biases
gives a 9-state filter.
"""

from __future__ import annotations

from dataclasses import dataclass

from sarnav.errors import ConfigError

_BLOCK_ORDER = ("p", "v", "th", "ba", "bg")
_BLOCK_NAMES = {
    "p": ("pN", "pE", "pD"),
    "v": ("vN", "vE", "vD"),
    "th": ("thN", "thE", "thD"),
    "ba": ("baX", "baY", "baZ"),
    "bg": ("bgX", "bgY", "bgZ"),
}
_BLOCK_UNITS = {"p": "m", "v": "m/s", "th": "rad", "ba": "m/s^2", "bg": "rad/s"}


@dataclass(frozen=True)
class ErrorStateLayout:
    """Index map of an error state.

    Parameters
    ----------
    scalar_biases : names of scalar FOGM measurement-bias states, in order.
    blocks : vector blocks; must start with ``("p", "v", "th")`` and keep the order p, v, th, ba, bg.
    scalar_units : units of the scalar biases (for result files), default "".
    """

    scalar_biases: tuple[str, ...] = ()
    blocks: tuple[str, ...] = ("p", "v", "th", "ba", "bg")
    scalar_units: tuple[str, ...] = ()

    def __post_init__(self):
        if tuple(self.blocks[:3]) != ("p", "v", "th"):
            raise ConfigError("layout.blocks", f"must start with ('p', 'v', 'th'), got {self.blocks}")
        order = [b for b in _BLOCK_ORDER if b in self.blocks]
        if list(self.blocks) != order or len(set(self.blocks)) != len(self.blocks):
            raise ConfigError("layout.blocks", f"must be an ordered subset of {_BLOCK_ORDER}, got {self.blocks}")
        if len(set(self.scalar_biases)) != len(self.scalar_biases):
            raise ConfigError("layout.scalar_biases", f"names must be unique, got {self.scalar_biases}")
        if self.scalar_units and len(self.scalar_units) != len(self.scalar_biases):
            raise ConfigError("layout.scalar_units", "must have one unit per scalar bias")

    @property
    def n(self) -> int:
        """Number of error states."""
        return 3 * len(self.blocks) + len(self.scalar_biases)

    def has(self, block: str) -> bool:
        return block in self.blocks

    def slice(self, block: str) -> slice:
        """Index range of a vector block ``p, v, th, ba, bg``."""
        if block not in self.blocks:
            raise KeyError(f"layout has no block {block!r} (blocks: {self.blocks})")
        i = self.blocks.index(block)
        return slice(3 * i, 3 * i + 3)

    @property
    def scalar_slice(self) -> slice:
        k = 3 * len(self.blocks)
        return slice(k, k + len(self.scalar_biases))

    def index(self, name: str) -> int:
        """Index of a scalar bias state by name."""
        try:
            return 3 * len(self.blocks) + self.scalar_biases.index(name)
        except ValueError:
            raise KeyError(f"layout has no scalar bias {name!r} (has {self.scalar_biases})") from None

    def state_names(self) -> list[str]:
        """``pN pE pD vN vE vD thN thE thD baX baY baZ bgX bgY bgZ`` + scalar bias names."""
        names = [n for b in self.blocks for n in _BLOCK_NAMES[b]]
        return names + list(self.scalar_biases)

    def state_units(self) -> list[str]:
        units = [_BLOCK_UNITS[b] for b in self.blocks for _ in range(3)]
        return units + list(self.scalar_units or [""] * len(self.scalar_biases))

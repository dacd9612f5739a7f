"""What a buffer holds, per frame: the figures ``zros tf frames`` and tf2's YAML show."""

from __future__ import annotations

from dataclasses import dataclass

_NS = 1_000_000_000


@dataclass(frozen=True)
class EdgeInfo:
    """What the buffer holds for one frame (``all_frames_as_yaml``, ``zros tf frames``)."""

    frame: str
    parent: str
    authority: str
    static: bool
    length: int  #: transforms held
    oldest: int  #: ns
    newest: int  #: ns
    received: int  #: transforms accepted since the edge was made

    @property
    def rate(self) -> float:
        """Transforms per second over what is held (tf2's figure: 10000 for a static one)."""
        span = max((self.newest - self.oldest) / _NS, 0.0001)
        return (1 if self.static else self.length) / span

    @property
    def buffer_length(self) -> float:
        """Seconds between the oldest and the newest transform held."""
        return (self.newest - self.oldest) / _NS


def frames_as_string(edges: list[EdgeInfo]) -> str:
    """One line per frame with a parent, as tf2 writes it."""
    return ''.join(f'Frame {e.frame} exists with parent {e.parent}.\n' for e in edges)


def frames_as_yaml(edges: list[EdgeInfo], now: int | None) -> str:
    """The frames as tf2's YAML; the delay too when ``now`` (ns) is given."""
    lines = []
    for e in edges:
        lines += [
            f'{e.frame}: ',
            f"  parent: '{e.parent}'",
            f"  broadcaster: '{e.authority}'",
            f'  rate: {e.rate:.3f}',
            f'  most_recent_transform: {e.newest / _NS:.3f}',
            f'  oldest_transform: {e.oldest / _NS:.3f}',
        ]
        if now:
            lines.append(f'  transform_delay: {(now - e.newest) / _NS:.3f}')
        lines.append(f'  buffer_length: {e.buffer_length:.3f}')
    return '\n'.join(lines) + ('\n' if lines else '')

"""The frame tree: which edges join two frames, and the errors when none do.

A chain from ``source`` to ``target`` goes up from ``source`` to the first frame both reach
(their common ancestor) and down to ``target``; its transform is
``inverse(T_ancestor_target) * T_ancestor_source``.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass

from zros.tf.cache import EdgeCache
from zros.tf.errors import ConnectivityException, InvalidArgumentException, LookupException
from zros.tf.quaternions import Pose7, compose

#: deeper than any real tree; a guard should a loop ever get in
MAX_DEPTH = 1000


@dataclass(frozen=True)
class Chain:
    """The edges from ``source`` up to the common ancestor (``up``) and from ``target`` up to
    it (``down``), each as ``(child frame, its cache)`` in walking order."""

    target: str
    source: str
    up: tuple[tuple[str, EdgeCache], ...]
    down: tuple[tuple[str, EdgeCache], ...]
    version: int
    #: ``up`` and ``down`` with each run of static edges composed into one constant
    up_steps: tuple[EdgeCache | Pose7, ...] = ()
    down_steps: tuple[EdgeCache | Pose7, ...] = ()

    @property
    def edges(self) -> tuple[tuple[str, EdgeCache], ...]:
        """Every edge of the chain."""
        return self.up + self.down

    @property
    def moving(self) -> tuple[tuple[str, EdgeCache], ...]:
        """The edges that change over time (not static)."""
        return tuple(edge for edge in self.edges if not edge[1].static)


def clean_frame(name: str, argument: str) -> str:
    """A frame name as stored: without a leading ``/`` (ROS 1 recordings have them)."""
    if not isinstance(name, str):
        raise InvalidArgumentException(
            f'{argument} must be a frame name (str), not {type(name).__name__}'
        )
    stripped = name.lstrip('/')
    if not stripped:
        raise InvalidArgumentException(f'{argument} is empty: a frame name is needed')
    return stripped


def ancestors(edges: Mapping[str, EdgeCache], frame: str) -> list[str]:
    """``frame`` and its parents up to the root of its tree."""
    path = [frame]
    edge = edges.get(frame)
    while edge is not None and len(path) <= MAX_DEPTH:
        path.append(edge.parent)
        edge = edges.get(edge.parent)
    return path


class UnknownFrame(LookupException):
    """A frame the buffer does not know. The text names the closest known frames, found only
    when it is read: a lookup waiting for a frame tries again at every arrival, and searching
    thousands of names each time would slow every transform that arrives."""

    def __init__(self, frame: str, argument: str, frames: list[str]) -> None:
        super().__init__(frame, argument)
        self.frame = frame
        self._argument = argument
        self._frames = frames
        self._text: str | None = None

    def __str__(self) -> str:
        if self._text is None:
            self._text = unknown_frame_text(self.frame, self._argument, self._frames)
        return self._text


def unknown_frame_text(frame: str, argument: str, frames: list[str]) -> str:
    """What a lookup of an unknown frame says, naming the closest known ones."""
    if not frames:
        hint = 'the buffer holds no frames yet'
    else:
        listed = sorted(frames)
        close = difflib.get_close_matches(frame, listed, n=3, cutoff=0.5)
        if close:
            hint = 'the closest known frames: ' + ', '.join(f'"{c}"' for c in close)
        else:
            more = f' and {len(listed) - 10} more' if len(listed) > 10 else ''
            hint = 'known frames: ' + ', '.join(f'"{c}"' for c in listed[:10]) + more
    return f'"{frame}" passed to lookup_transform argument {argument} does not exist; {hint}'


def too_deep(frame: str) -> LookupException:
    """tf2's error for a chain past its graph depth (which it takes for a loop)."""
    return LookupException(
        f'the chain from "{frame}" up to its root is deeper than {MAX_DEPTH} frames: tf2 takes '
        'a tree that deep to contain a loop'
    )


def find_chain(
    edges: Mapping[str, EdgeCache], frames: set[str], target: str, source: str, version: int
) -> Chain:
    """The chain of edges from ``source`` to ``target`` (Lookup or ConnectivityException)."""
    for frame, argument in ((target, 'target_frame'), (source, 'source_frame')):
        if frame not in frames:
            raise UnknownFrame(frame, argument, list(frames))
    up_frames = ancestors(edges, source)
    if len(up_frames) > MAX_DEPTH:
        raise too_deep(source)
    index = {frame: i for i, frame in enumerate(up_frames)}
    down_frames = [target]
    while down_frames[-1] not in index:
        edge = edges.get(down_frames[-1])
        if len(down_frames) > MAX_DEPTH:
            raise too_deep(target)
        if edge is None:
            root_source = up_frames[-1]
            root_target = down_frames[-1]
            raise ConnectivityException(
                f'Could not find a connection between "{target}" and "{source}" because they '
                f'are not part of the same tree: "{target}" is in the tree rooted at '
                f'"{root_target}", "{source}" in the tree rooted at "{root_source}". Tf has '
                'two or more unconnected trees.'
            )
        down_frames.append(edge.parent)
    common = index[down_frames[-1]]
    up = tuple((frame, edges[frame]) for frame in up_frames[:common])
    down = tuple((frame, edges[frame]) for frame in down_frames[:-1])
    return Chain(target, source, up, down, version, _fold(up), _fold(down))


def _fold(edges: tuple[tuple[str, EdgeCache], ...]) -> tuple[EdgeCache | Pose7, ...]:
    """The edges in walking order, each run of static ones composed into one transform."""
    steps: list[EdgeCache | Pose7] = []
    for _, edge in edges:
        if not edge.static:
            steps.append(edge)
        elif steps and isinstance(steps[-1], tuple):
            steps[-1] = compose(edge.at(0), steps[-1])
        else:
            steps.append(edge.at(0))
    return tuple(steps)

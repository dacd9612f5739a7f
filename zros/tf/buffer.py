"""The transform buffer: tf2's ``BufferCore`` and ``tf2_ros.Buffer`` without ROS.

Edges are stored per child frame (:mod:`zros.tf.cache`); lookups find the chain of edges
(:mod:`zros.tf.tree`), sample each edge at the time asked, and compose. One lookup runs on
Python floats; :meth:`Buffer.lookup_transforms` runs on numpy arrays for any number of stamps.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from zros.cdr import Message, get_class
from zros.runtime.clock import Duration
from zros.runtime.signal import Signal, interrupted
from zros.tf import checks
from zros.tf.bag_transforms import read_transforms
from zros.tf.cache import EdgeCache, OutOfRange
from zros.tf.checks import Authority
from zros.tf.errors import (
    ExtrapolationException,
    InvalidArgumentException,
    TransformException,
)
from zros.tf.many import Many, compose_many, invert_many, sample
from zros.tf.quaternions import (
    IDENTITY,
    Pose7,
    compose,
    invert,
    rotate,
)
from zros.tf.times import TimeLike, TimeoutLike, format_time, nanoseconds, seconds
from zros.tf.tree import Chain, ancestors, clean_frame, find_chain

if TYPE_CHECKING:
    from pathlib import Path

    from zros.bag import Bag

_NS = 1_000_000_000
#: frames a live buffer takes before refusing new ones (a flood of names must not grow it)
MAX_FRAMES = 10_000
#: transforms one live edge keeps, whatever its rate
MAX_EDGE_LENGTH = 100_000


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


class Buffer:
    """Transforms over time, for lookups between any two frames (tf2_ros's ``Buffer``).

    >>> buffer = Buffer()                                         # doctest: +SKIP
    >>> listener = TransformListener(buffer, node)
    >>> t = buffer.lookup_transform('map', 'base_link', 0, timeout=1.0)

    ``cache_time`` (seconds or a ``Duration``; None keeps everything, as
    :meth:`from_bag` does) is how much history each moving edge keeps before its newest
    transform. Times are integer nanoseconds, ``zros.Time`` or ``builtin_interfaces/msg/Time``;
    time 0 means the latest instant at which the whole chain is known.
    """

    def __init__(self, cache_time: float | Duration | None = 10.0) -> None:
        window = seconds(cache_time)
        self.cache_time: int | None = None if window is None else round(window * _NS)
        self._edges: dict[str, EdgeCache] = {}
        self._frames: set[str] = set()
        self._version = 0
        self._chains: dict[tuple[str, str], Chain] = {}
        self._lock = threading.Lock()
        self._arrived = Signal()
        self.rejections = checks.Rejections()  #: refused transforms: ``.counts`` by tf2 code

    # --- filling -------------------------------------------------------------------------

    def set_transform(self, transform: Message, authority: Authority) -> bool:
        """Add a ``geometry_msgs/msg/TransformStamped``; False if it was refused (logged)."""
        return self._add_message(transform, authority, static=False)

    def set_transform_static(self, transform: Message, authority: Authority) -> bool:
        """Add a transform valid at every time (as from ``/tf_static``)."""
        return self._add_message(transform, authority, static=True)

    def _add_message(self, transform: Message, authority: Authority, *, static: bool) -> bool:
        header = transform.header
        t = transform.transform.translation
        q = transform.transform.rotation
        pose = (t.x, t.y, t.z, q.x, q.y, q.z, q.w)
        stamp = header.stamp.sec * _NS + header.stamp.nanosec
        added = self.add(
            header.frame_id, transform.child_frame_id, stamp, pose, authority, static=static
        )
        if added:
            self._arrived.notify()
        return added

    def add(
        self,
        parent: str,
        child: str,
        stamp: int,
        pose: Pose7,
        authority: Authority,
        *,
        static: bool = False,
    ) -> bool:
        """Add one transform of ``child`` in ``parent`` (translation, quaternion x y z w) at
        ``stamp`` ns; False if it was refused (counted in :attr:`rejections`, logged once per
        sender). Waiting lookups are not woken (:meth:`set_transform` does that)."""
        parent, child = parent.lstrip('/'), child.lstrip('/')
        problem = checks.check(child, parent, pose, authority)
        if problem is not None:
            self.rejections.report(problem[0], authority, child, problem[1])
            return False
        pose = checks.normalized(pose)
        with self._lock:
            edge = self._edge_for(parent, child, stamp, authority, static)
            if edge is None:
                return False
            refused = edge.insert(stamp, pose)
            if refused is None:
                edge.authority = authority
                if edge.static:  # chains fold static edges into constants: fold anew
                    self._version += 1
                    self._chains.clear()
                return True
        if refused == 'TF_OLD_DATA':
            message = (
                f'TF_OLD_DATA ignoring data from the past for frame {child} at time '
                f'{format_time(stamp)} according to authority {authority}: the buffer keeps '
                f'{format_time(edge.max_age or 0)} s before its newest transform, at '
                f'{format_time(edge.newest)}'
            )
        else:
            message = (
                f'TF_REPEATED_DATA ignoring data with redundant timestamp for frame {child} '
                f'(parent {edge.parent}) at time {format_time(stamp)} according to authority '
                f'{authority}'
            )
        self.rejections.report(refused, authority, child, message)
        return False

    def _edge_for(
        self, parent: str, child: str, stamp: int, authority: Authority, static: bool
    ) -> EdgeCache | None:
        """The edge to insert into (made if new); None when the transform is refused."""
        edge = self._edges.get(child)
        if edge is not None:
            if edge.parent == parent:
                return edge
            expired = (
                not edge.static
                and self.cache_time is not None
                and stamp - edge.newest > self.cache_time
            )
            if not expired:
                message = (
                    f'TF_TWO_PARENTS: Ignoring transform for child_frame_id "{child}" from '
                    f'authority "{authority}" with frame_id "{parent}": "{child}" already has '
                    f'the parent "{edge.parent}" (from authority "{edge.authority}"), and a '
                    'frame has one parent'
                )
                self.rejections.report(checks.TWO_PARENTS, authority, child, message)
                return None
        chain = ancestors(self._edges, parent)
        if child in chain:
            loop = ' -> '.join([child, *chain[: chain.index(child) + 1]])
            message = (
                f'TF_LOOP: Ignoring transform for child_frame_id "{child}" from authority '
                f'"{authority}" with frame_id "{parent}": it would close a loop ({loop})'
            )
            self.rejections.report(checks.LOOP, authority, child, message)
            return None
        if edge is None and self.cache_time is not None and len(self._edges) >= MAX_FRAMES:
            message = (
                f'TF_TOO_MANY_FRAMES: Ignoring transform for child_frame_id "{child}" from '
                f'authority "{authority}": the buffer holds {MAX_FRAMES} frames already'
            )
            self.rejections.report(checks.TOO_MANY_FRAMES, authority, child, message)
            return None
        edge = EdgeCache(
            parent,
            static=static,
            max_age=self.cache_time,
            max_length=None if self.cache_time is None else MAX_EDGE_LENGTH,
        )
        self._edges[child] = edge
        self._frames.add(child)
        self._frames.add(parent)
        self._version += 1
        self._chains.clear()
        return edge

    def clear(self) -> None:
        """Forget every transform."""
        with self._lock:
            self._edges.clear()
            self._frames.clear()
            self._chains.clear()
            self._version += 1

    # --- single lookups --------------------------------------------------------------------

    def _chain(self, target: str, source: str) -> Chain:
        key = (target, source)
        chain = self._chains.get(key)
        if chain is None:
            chain = find_chain(self._edges, self._frames, target, source, self._version)
            if len(self._chains) > 10_000:
                self._chains.clear()
            self._chains[key] = chain
        return chain

    def _pose(self, target: str, source: str, stamp: int) -> tuple[Pose7, int]:
        """T_target_source at ``stamp`` (0: the latest common time), and the stamp used."""
        if target == source:
            if source not in self._frames:
                find_chain(self._edges, self._frames, target, source, self._version)
            return IDENTITY, stamp
        chain = self._chain(target, source)
        if stamp == 0:
            stamp = _latest_common(chain)
        try:
            up = _through(chain.up_steps, stamp)
            down = _through(chain.down_steps, stamp)
        except OutOfRange as exc:
            raise _extrapolation(chain, stamp, exc) from None
        if not chain.down:
            return up, stamp
        return compose(invert(down), up), stamp

    def lookup_transform(
        self,
        target_frame: str,
        source_frame: str,
        time: TimeLike,
        timeout: TimeoutLike = None,
    ) -> Message:
        """The ``geometry_msgs/msg/TransformStamped`` taking data in ``source_frame`` to
        ``target_frame`` at ``time`` (0: the latest common time). With ``timeout`` (seconds),
        waits for the data to arrive; Ctrl-C ends the wait with KeyboardInterrupt.

        Raises :class:`LookupException`, :class:`ConnectivityException`,
        :class:`ExtrapolationException` (all :class:`TransformException`).
        """
        target = clean_frame(target_frame, 'target_frame')
        source = clean_frame(source_frame, 'source_frame')
        stamp = nanoseconds(time)
        self._wait(lambda: self._pose(target, source, stamp), timeout)
        with self._lock:
            pose, used = self._pose(target, source, stamp)
        return transform_message(target, source, used, pose)

    def lookup_transform_full(  # noqa: PLR0917 (tf2_ros's signature)
        self,
        target_frame: str,
        target_time: TimeLike,
        source_frame: str,
        source_time: TimeLike,
        fixed_frame: str,
        timeout: TimeoutLike = None,
    ) -> Message:
        """Data in ``source_frame`` at ``source_time`` to ``target_frame`` at
        ``target_time``, through ``fixed_frame`` (a frame that does not move between the two
        times, such as ``map`` or ``odom``)."""
        target = clean_frame(target_frame, 'target_frame')
        source = clean_frame(source_frame, 'source_frame')
        fixed = clean_frame(fixed_frame, 'fixed_frame')
        target_stamp = nanoseconds(target_time, 'target_time')
        source_stamp = nanoseconds(source_time, 'source_time')

        def full() -> tuple[Pose7, int]:
            fixed_source, _ = self._pose(fixed, source, source_stamp)
            target_fixed, used = self._pose(target, fixed, target_stamp)
            return compose(target_fixed, fixed_source), used

        self._wait(full, timeout)
        with self._lock:
            pose, used = full()
        return transform_message(target, source, used, pose)

    def can_transform(
        self,
        target_frame: str,
        source_frame: str,
        time: TimeLike,
        timeout: TimeoutLike = None,
    ) -> bool:
        """Whether :meth:`lookup_transform` would succeed (waiting up to ``timeout``)."""
        return _succeeds(lambda: self.lookup_transform(target_frame, source_frame, time, timeout))

    def can_transform_full(  # noqa: PLR0917 (tf2_ros's signature)
        self,
        target_frame: str,
        target_time: TimeLike,
        source_frame: str,
        source_time: TimeLike,
        fixed_frame: str,
        timeout: TimeoutLike = None,
    ) -> bool:
        """Whether :meth:`lookup_transform_full` would succeed (waiting up to ``timeout``)."""
        return _succeeds(
            lambda: self.lookup_transform_full(
                target_frame, target_time, source_frame, source_time, fixed_frame, timeout
            )
        )

    def _wait(self, attempt: Callable[[], object], timeout: TimeoutLike) -> None:
        """Wait until ``attempt()`` stops raising TransformException, or ``timeout`` runs out
        (then return: the caller's own attempt raises). KeyboardInterrupt on Ctrl-C."""
        wait = seconds(timeout)
        if not wait or wait <= 0:
            return

        def ready() -> bool:
            with self._lock:
                return _succeeds(attempt)

        if not self._arrived.wait_for(ready, wait) and interrupted():
            raise KeyboardInterrupt

    # --- many stamps at once -----------------------------------------------------------------

    def lookup_transforms(
        self,
        target_frame: str,
        source_frame: str,
        times: np.ndarray | Sequence[int],
        *,
        strict: bool = False,
    ) -> tuple[np.ndarray, np.ndarray]:
        """T_target_source at each of ``times`` (int64 nanoseconds), computed with numpy over
        the whole array: ``(translations (N, 3), rotations (N, 4) as x y z w)``.

        Stamps outside what the chain covers give NaN rows; with ``strict=True`` the first
        such stamp raises :class:`ExtrapolationException` instead. A stamp of 0 is the instant
        0 here, not "the latest" as for one lookup.
        """
        target = clean_frame(target_frame, 'target_frame')
        source = clean_frame(source_frame, 'source_frame')
        stamps = np.asarray(times)
        if stamps.ndim != 1 or not (stamps.dtype.kind in 'iu' or stamps.size == 0):
            raise InvalidArgumentException(
                'times must be a 1-D array of integer nanoseconds (int64), '
                f'not {stamps.dtype} of shape {stamps.shape}'
            )
        stamps = stamps.astype(np.int64, copy=False)
        count = len(stamps)
        with self._lock:
            if target == source:
                if source not in self._frames:
                    find_chain(self._edges, self._frames, target, source, self._version)
                chain = None
            else:
                chain = self._chain(target, source)
                snapshot = [
                    (edge, _edge_data(edge, self.cache_time is not None)) for _, edge in chain.edges
                ]
        if chain is None:
            translations = np.zeros((count, 3))
            rotations = np.zeros((count, 4))
            rotations[:, 3] = 1.0
            return translations, rotations
        data = dict(snapshot)
        valid = np.ones(count, dtype=bool)

        def walk(edges: tuple[tuple[str, EdgeCache], ...]) -> Many:
            pose: Many = IDENTITY
            for _, edge in edges:
                edge_stamps, rows = data[edge]
                sampled, covered = sample(edge.static, edge_stamps, rows, stamps)
                if covered is not None:
                    valid[:] &= covered
                pose = compose_many(sampled, pose)
            return pose

        up = walk(chain.up)
        pose = compose_many(invert_many(walk(chain.down)), up) if chain.down else up
        if len(pose) == 7:
            t = np.array(np.broadcast_to(np.asarray(pose[:3]), (count, 3)))
            q = np.array(np.broadcast_to(np.asarray(pose[3:]), (count, 4)))
        else:
            t, q = pose
        if not valid.all():
            first = int(np.argmin(valid))
            if strict:
                with self._lock:
                    try:
                        self._pose(target, source, int(stamps[first]))
                    except ExtrapolationException as exc:
                        raise ExtrapolationException(f'times[{first}]: {exc}') from None
            t[~valid] = np.nan
            q[~valid] = np.nan
        return t, q

    def stamps(self, target_frame: str, source_frame: str) -> np.ndarray:
        """Every stamp (int64 ns) at which a moving edge of the chain has a transform and the
        whole chain is covered, sorted: where the chain's transform changes."""
        target = clean_frame(target_frame, 'target_frame')
        source = clean_frame(source_frame, 'source_frame')
        with self._lock:
            if target == source:
                return np.zeros(0, dtype=np.int64)
            chain = self._chain(target, source)
            moving = [edge.stamps.copy() for _, edge in chain.moving]
        if not moving:
            return np.zeros(0, dtype=np.int64)
        low = max(int(s[0]) for s in moving)
        high = min(int(s[-1]) for s in moving)
        every = np.unique(np.concatenate(moving))
        return every[(every >= low) & (every <= high)]

    # --- transforming data -----------------------------------------------------------------

    def transform(
        self,
        obj: Message,
        target_frame: str,
        timeout: TimeoutLike = None,
    ) -> Message:
        """``obj`` (a ``PointStamped``, ``PoseStamped``, ``Vector3Stamped`` or
        ``PoseWithCovarianceStamped``) in ``target_frame``, at its header's stamp."""
        from zros.tf.stamped import transform_stamped

        transform = self.lookup_transform(
            target_frame, obj.header.frame_id, obj.header.stamp, timeout
        )
        return transform_stamped(obj, transform)

    def transform_points(
        self,
        points: np.ndarray,
        target_frame: str,
        source_frame: str,
        time: TimeLike,
        timeout: TimeoutLike = None,
    ) -> np.ndarray:
        """Points ``(N, 3)`` given in ``source_frame`` at ``time``, in ``target_frame``."""
        array = np.asarray(points, dtype=np.float64)
        if array.ndim != 2 or array.shape[1] != 3:
            raise InvalidArgumentException(f'points must have shape (N, 3), not {array.shape}')
        target = clean_frame(target_frame, 'target_frame')
        source = clean_frame(source_frame, 'source_frame')
        stamp = nanoseconds(time)
        self._wait(lambda: self._pose(target, source, stamp), timeout)
        with self._lock:
            pose, _ = self._pose(target, source, stamp)
        moved: np.ndarray = np.asarray(pose[:3]) + rotate(np.asarray(pose[3:])[None, :], array)
        return moved

    # --- what it holds ---------------------------------------------------------------------

    def edges(self) -> list[EdgeInfo]:
        """What the buffer holds for each frame that has a parent, sorted by frame."""
        with self._lock:
            return [
                EdgeInfo(
                    frame=frame,
                    parent=edge.parent,
                    authority=str(edge.authority),
                    static=edge.static,
                    length=len(edge),
                    oldest=edge.oldest,
                    newest=edge.newest,
                    received=edge.received,
                )
                for frame, edge in sorted(self._edges.items())
                if len(edge)
            ]

    def frames(self) -> set[str]:
        """Every frame the buffer knows."""
        with self._lock:
            return set(self._frames)

    def all_frames_as_string(self) -> str:
        """One line per frame with a parent, as tf2 writes it."""
        return ''.join(f'Frame {e.frame} exists with parent {e.parent}.\n' for e in self.edges())

    def all_frames_as_yaml(self, current_time: TimeLike | None = None) -> str:
        """The frames as tf2's YAML (parent, broadcaster, rate, most recent and oldest
        transform, buffer length; the delay too when ``current_time`` is given)."""
        now = None if current_time is None else nanoseconds(current_time, 'current_time')
        lines = []
        for e in self.edges():
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

    # --- recordings ----------------------------------------------------------------------------

    @classmethod
    def from_bag(
        cls,
        bag: Bag | str | Path,
        topics: Iterable[str] = ('/tf', '/tf_static'),
    ) -> Buffer:
        """A buffer holding every transform of a recording (no cache window). Topics whose
        name ends in ``tf_static`` hold static transforms. ROS 1 ``tf/tfMessage`` and
        ``tf2_msgs/msg/TFMessage`` are read; the recording's other topics are not."""
        buffer = cls(cache_time=None)
        for batch in read_transforms(bag, tuple(topics), buffer.rejections):
            buffer._extend(
                batch.parent,
                batch.child,
                batch.stamps,
                batch.rows,
                authority=batch.authority,
                static=batch.static,
            )
        return buffer

    def _extend(
        self,
        parent: str,
        child: str,
        stamps: np.ndarray,
        rows: np.ndarray,
        *,
        authority: Authority,
        static: bool,
    ) -> int:
        """Add a batch of checked transforms of one edge; how many it refused."""
        with self._lock:
            edge = self._edge_for(parent, child, int(stamps[-1]), authority, static)
            if edge is None:
                return len(stamps)
            repeated = edge.extend(stamps, rows)
            edge.authority = authority
            self._version += 1
            self._chains.clear()
        if repeated:
            message = (
                f'TF_REPEATED_DATA ignoring {repeated} transforms with redundant timestamps for '
                f'frame {child} (parent {parent}) according to authority {authority}'
            )
            self.rejections.report('TF_REPEATED_DATA', authority, child, message)
        return repeated

    def __repr__(self) -> str:
        window = 'all' if self.cache_time is None else f'{self.cache_time / _NS:g} s'
        return f'<zros.tf.Buffer {len(self._frames)} frames, cache {window}>'


def _through(steps: tuple[EdgeCache | Pose7, ...], stamp: int) -> Pose7:
    """The chain's steps at ``stamp`` composed (the top of the walk in its bottom)."""
    pose = IDENTITY
    for number, step in enumerate(steps):
        here = step if isinstance(step, tuple) else step.at(stamp)
        pose = here if number == 0 else compose(here, pose)
    return pose


def _succeeds(attempt: Callable[[], object]) -> bool:
    """Whether ``attempt()`` returns instead of raising a TransformException."""
    try:
        attempt()
    except TransformException:
        return False
    return True


def _latest_common(chain: Chain) -> int:
    moving = chain.moving
    if not moving:
        return 0
    return min(edge.newest for _, edge in moving)


def _extrapolation(chain: Chain, stamp: int, exc: OutOfRange) -> ExtrapolationException:
    route = f'when looking up transform from frame [{chain.source}] to frame [{chain.target}]'
    if exc.side == 'only':
        head = (
            f'Lookup would require extrapolation at time {format_time(stamp)}, but only time '
            f'{format_time(exc.oldest)} is in the buffer, {route}'
        )
    elif exc.side == 'past':
        head = (
            'Lookup would require extrapolation into the past. Requested time '
            f'{format_time(stamp)} but the earliest data is at time {format_time(exc.oldest)}, '
            f'{route}'
        )
    else:
        head = (
            'Lookup would require extrapolation into the future. Requested time '
            f'{format_time(stamp)} but the latest data is at time {format_time(exc.newest)}, '
            f'{route}'
        )
    moving = chain.moving
    low = max(edge.oldest for _, edge in moving)
    high = min(edge.newest for _, edge in moving)
    if low <= high:
        covered = f'the chain has data from {format_time(low)} to {format_time(high)}'
    else:
        spans = ', '.join(
            f'{edge.parent} -> {child} [{format_time(edge.oldest)}, {format_time(edge.newest)}]'
            for child, edge in moving
        )
        covered = f'no instant is covered by every moving edge of the chain ({spans})'
    return ExtrapolationException(f'{head}; {covered}')


def _edge_data(edge: EdgeCache, copy: bool) -> tuple[np.ndarray, np.ndarray]:
    stamps: np.ndarray = edge.stamps
    rows: np.ndarray = edge.rows
    if copy:
        return stamps.copy(), rows.copy()
    return stamps, rows


def transform_message(target: str, source: str, stamp: int, pose: Pose7) -> Message:
    """A ``geometry_msgs/msg/TransformStamped`` of ``source`` in ``target``."""
    sec, nanosec = divmod(stamp, _NS)
    x, y, z, qx, qy, qz, qw = pose
    c = _classes()
    return c.stamped(  # positional: a third cheaper than keywords, on the path of every lookup
        c.header(c.time(sec, nanosec), target),
        source,
        c.transform(c.vector(x, y, z), c.quaternion(qx, qy, qz, qw)),
    )


@dataclass(frozen=True)
class _Classes:
    stamped: type[Message]
    header: type[Message]
    time: type[Message]
    transform: type[Message]
    vector: type[Message]
    quaternion: type[Message]


_CLASSES: list[_Classes] = []


def _classes() -> _Classes:
    if not _CLASSES:
        _CLASSES.append(
            _Classes(
                get_class('geometry_msgs/msg/TransformStamped'),
                get_class('std_msgs/msg/Header'),
                get_class('builtin_interfaces/msg/Time'),
                get_class('geometry_msgs/msg/Transform'),
                get_class('geometry_msgs/msg/Vector3'),
                get_class('geometry_msgs/msg/Quaternion'),
            )
        )
    return _CLASSES[0]

"""The transform buffer: tf2's ``BufferCore`` and ``tf2_ros.Buffer`` without ROS.

Edges are stored per child frame (:mod:`zros.tf.cache`); lookups find the chain of edges
(:mod:`zros.tf.tree`), sample each edge at the time asked, and compose. One lookup runs on
Python floats; :meth:`Buffer.lookup_transforms` runs on numpy arrays for any number of stamps.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Literal, TypeVar, overload

import numpy as np

from zros.cdr import Message
from zros.runtime.clock import Duration, Time
from zros.runtime.futures import ServiceFuture
from zros.runtime.signal import Signal, interrupted
from zros.tf import checks
from zros.tf.bag_transforms import read_transforms
from zros.tf.cache import OutOfRange
from zros.tf.checks import Authority
from zros.tf.edge_tree import EdgeTree
from zros.tf.errors import (
    ConnectivityException,
    ExtrapolationException,
    InvalidArgumentException,
    TransformException,
)
from zros.tf.messages import transform_message
from zros.tf.quaternions import (
    IDENTITY,
    Pose7,
    compose,
    invert,
    rotate,
)
from zros.tf.report import EdgeInfo, frames_as_string, frames_as_yaml
from zros.tf.stamped import transform_stamped
from zros.tf.times import TimeLike, TimeoutLike, nanoseconds, seconds
from zros.tf.tree import Chain, clean_frame
from zros.tf.walk import edge_data, extrapolation, latest_common, sample_chain, through

if TYPE_CHECKING:
    from pathlib import Path

    from zros.bag import Bag
    from zros.runtime.defaults import NodeLike
    from zros.tf.quaternions import Floats, Stamps

_NS = 1_000_000_000
#: stamps looked up under one hold of the lock when they go one at a time
ONE_BY_ONE = 1000
T = TypeVar('T')


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

    def __init__(
        self, cache_time: float | Duration | None = 10.0, node: NodeLike | None = None
    ) -> None:
        #: rclpy's ``Buffer(cache_time, node)``: the node is only kept; a
        #: :class:`TransformListener` on a node clears the buffer when its clock jumps back
        self.node = node
        window = seconds(cache_time)
        self.cache_time: int | None = None if window is None else round(window * _NS)
        self._lock = threading.Lock()
        self._arrived = Signal()
        #: the pending ``*_async`` waits, each tried as transforms arrive (True: it is done)
        self._watchers: list[Callable[[], bool]] = []
        self._watch_lock = threading.Lock()
        self.rejections = checks.Rejections()  #: refused transforms: ``.counts`` by tf2 code
        self._tree = EdgeTree(self.cache_time, self.rejections)  # under _lock

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
            if self._watchers:
                self._try_watchers()
        return added

    def _try_watchers(self) -> None:
        with self._watch_lock:
            watchers = list(self._watchers)
        done = [watcher for watcher in watchers if watcher()]
        if done:
            with self._watch_lock:
                self._watchers = [w for w in self._watchers if w not in done]

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
            edge = self._tree.edge_for(parent, child, stamp, authority, static)
            if edge is None:
                return False
            refused = edge.insert(stamp, pose)
            if refused is None:
                edge.authority = authority
                if edge.static:  # chains fold static edges into constants: fold anew
                    self._tree.changed()
                self._tree.inserted(child, edge)
                return True
        if refused == 'TF_OLD_DATA':
            message = checks.old_data(child, stamp, authority, edge.max_age or 0, edge.newest)
        else:
            message = checks.repeated_data(child, edge.parent, stamp, authority)
        self.rejections.report(refused, authority, child, message)
        return False

    def clear(self) -> None:
        """Forget every moving transform; static ones stay, as with tf2's ``clear``. A
        :class:`TransformListener` calls it when its node's clock jumps back (a bag played in
        a loop with ``/clock``), as tf2_ros's buffer does."""
        with self._lock:
            self._tree.clear()

    # --- single lookups --------------------------------------------------------------------

    def _pose(self, target: str, source: str, stamp: int) -> tuple[Pose7, int]:
        """T_target_source at ``stamp`` (0: the latest common time), and the stamp used."""
        if target == source:
            self._tree.check_known(target, source)
            return IDENTITY, stamp
        chain = self._tree.fixed_chain(target, source)
        if stamp == 0:  # each frame's newest parent, as tf2's getLatestCommonTime walks
            stamp = latest_common(chain if chain is not None else self._tree.chain(target, source))
        return self._walk(chain, target, source, stamp), stamp

    def _walk(self, chain: Chain | None, target: str, source: str, stamp: int) -> Pose7:
        """T_target_source at the instant ``stamp`` along ``chain`` (:meth:`EdgeTree.fixed_chain`);
        None, through a frame that changed parent: along the chain as the tree was then."""
        if chain is None:
            chain = self._tree.chain_at(target, source, stamp)
        try:
            up = through(chain.up_steps, stamp)
            down = through(chain.down_steps, stamp)
        except OutOfRange as exc:
            raise extrapolation(chain, stamp, exc) from None
        if not chain.down:
            return up
        return compose(invert(down), up)

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
        pose, used = self._attempt(lambda: self._pose(target, source, stamp), timeout)
        return transform_message(target, source, used, pose)

    def get_latest_common_time(self, target_frame: str, source_frame: str) -> Time:
        """The latest instant at which the whole chain between the frames is known (what a
        lookup at time 0 uses; 0 for a chain of static edges), as rclpy's Buffer has it.

        Raises :class:`LookupException` or :class:`ConnectivityException`.
        """
        target = clean_frame(target_frame, 'target_frame')
        source = clean_frame(source_frame, 'source_frame')
        with self._lock:
            if target == source:
                self._tree.check_known(target, source)
                return Time(0)
            return Time(latest_common(self._tree.chain(target, source)))

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

        pose, used = self._attempt(full, timeout)
        return transform_message(target, source, used, pose)

    @overload
    def can_transform(
        self,
        target_frame: str,
        source_frame: str,
        time: TimeLike,
        timeout: TimeoutLike = None,
        return_debug_tuple: Literal[False] = False,
    ) -> bool: ...

    @overload
    def can_transform(
        self,
        target_frame: str,
        source_frame: str,
        time: TimeLike,
        timeout: TimeoutLike = None,
        *,
        return_debug_tuple: Literal[True],
    ) -> tuple[bool, str]: ...

    def can_transform(
        self,
        target_frame: str,
        source_frame: str,
        time: TimeLike,
        timeout: TimeoutLike = None,
        return_debug_tuple: bool = False,
    ) -> bool | tuple[bool, str]:
        """Whether :meth:`lookup_transform` would succeed (waiting up to ``timeout``); with
        ``return_debug_tuple`` (rclpy's), ``(whether, why not)``."""
        failure = _outcome(lambda: self.lookup_transform(target_frame, source_frame, time, timeout))
        return _debug(failure, return_debug_tuple)

    @overload
    def can_transform_full(
        self,
        target_frame: str,
        target_time: TimeLike,
        source_frame: str,
        source_time: TimeLike,
        fixed_frame: str,
        timeout: TimeoutLike = None,
        return_debug_tuple: Literal[False] = False,
    ) -> bool: ...

    @overload
    def can_transform_full(
        self,
        target_frame: str,
        target_time: TimeLike,
        source_frame: str,
        source_time: TimeLike,
        fixed_frame: str,
        timeout: TimeoutLike = None,
        *,
        return_debug_tuple: Literal[True],
    ) -> tuple[bool, str]: ...

    def can_transform_full(  # noqa: PLR0917 (tf2_ros's signature)
        self,
        target_frame: str,
        target_time: TimeLike,
        source_frame: str,
        source_time: TimeLike,
        fixed_frame: str,
        timeout: TimeoutLike = None,
        return_debug_tuple: bool = False,
    ) -> bool | tuple[bool, str]:
        """Whether :meth:`lookup_transform_full` would succeed (waiting up to ``timeout``); with
        ``return_debug_tuple``, ``(whether, why not)``."""
        failure = _outcome(
            lambda: self.lookup_transform_full(
                target_frame, target_time, source_frame, source_time, fixed_frame, timeout
            )
        )
        return _debug(failure, return_debug_tuple)

    # --- waiting without blocking (rclpy's async API) ------------------------------------

    def wait_for_transform_async(
        self, target_frame: str, source_frame: str, time: TimeLike
    ) -> ServiceFuture[Message]:
        """A future that is done with the transform once :meth:`lookup_transform` can give it
        (rclpy's): ``await`` it or ``.result(timeout)``. It is tried as transforms arrive, on
        the thread that adds them; a bad argument fails it at once, Ctrl-C fails it with
        KeyboardInterrupt."""
        return self._when_found(lambda: self.lookup_transform(target_frame, source_frame, time))

    def wait_for_transform_full_async(
        self,
        target_frame: str,
        target_time: TimeLike,
        source_frame: str,
        source_time: TimeLike,
        fixed_frame: str,
    ) -> ServiceFuture[Message]:
        """:meth:`wait_for_transform_async` for :meth:`lookup_transform_full`."""
        return self._when_found(
            lambda: self.lookup_transform_full(
                target_frame, target_time, source_frame, source_time, fixed_frame
            )
        )

    async def lookup_transform_async(
        self, target_frame: str, source_frame: str, time: TimeLike
    ) -> Message:
        """:meth:`lookup_transform`, waiting for the data without blocking an event loop."""
        return await self.wait_for_transform_async(target_frame, source_frame, time)

    async def lookup_transform_full_async(
        self,
        target_frame: str,
        target_time: TimeLike,
        source_frame: str,
        source_time: TimeLike,
        fixed_frame: str,
    ) -> Message:
        """:meth:`lookup_transform_full`, waiting for the data without blocking an event loop."""
        return await self.wait_for_transform_full_async(
            target_frame, target_time, source_frame, source_time, fixed_frame
        )

    def _when_found(self, lookup: Callable[[], Message]) -> ServiceFuture[Message]:
        future: ServiceFuture[Message] = ServiceFuture()

        def attempt() -> bool:
            if future.done():  # Ctrl-C failed it
                return True
            try:
                future.settle(lookup())
            except InvalidArgumentException as exc:  # no transform will mend it
                future.settle(exc)
            except TransformException:
                return False
            return True

        if not attempt():
            with self._watch_lock:
                self._watchers.append(attempt)
            attempt()  # a transform may have come before the watcher was in place
        return future

    def _attempt(self, attempt: Callable[[], T], timeout: TimeoutLike) -> T:
        """``attempt()`` under the lock, once it stops raising TransformException or
        ``timeout`` runs out (then it raises). KeyboardInterrupt on Ctrl-C."""
        wait = seconds(timeout)

        def ready() -> bool:
            with self._lock:
                return _outcome(attempt) is None

        if wait and wait > 0 and not self._arrived.wait_for(ready, wait) and interrupted():
            raise KeyboardInterrupt
        with self._lock:
            return attempt()

    # --- many stamps at once -----------------------------------------------------------------

    def lookup_transforms(
        self,
        target_frame: str,
        source_frame: str,
        times: Stamps | Sequence[int],
        *,
        strict: bool = False,
    ) -> tuple[Floats, Floats]:
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
                self._tree.check_known(target, source)
                chain = None
            else:
                chain = self._tree.fixed_chain(target, source)
                if chain is not None:
                    snapshot = [
                        (edge, edge_data(edge, self.cache_time is not None))
                        for _, edge in chain.edges
                    ]
        if chain is None and target != source:  # through a frame that changed parent
            return self._one_by_one(target, source, stamps, strict)
        if chain is None:
            translations = np.zeros((count, 3))
            rotations = np.zeros((count, 4))
            rotations[:, 3] = 1.0
            return translations, rotations
        t, q, valid = sample_chain(chain, dict(snapshot), stamps)
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

    def _one_by_one(
        self, target: str, source: str, stamps: Stamps, strict: bool
    ) -> tuple[Floats, Floats]:
        """What :meth:`lookup_transforms` gives, one stamp at a time: for a chain through a
        frame that changed parent, whose edges depend on the time. The lock is taken for
        :data:`ONE_BY_ONE` stamps at a time, so a listener's transforms are not held up. A
        stamp at which the frames are not joined is NaN too, unless they never are."""
        translations = np.full((len(stamps), 3), np.nan)
        rotations = np.full((len(stamps), 4), np.nan)
        apart: ConnectivityException | None = None
        listed = stamps.tolist()
        for first in range(0, len(listed), ONE_BY_ONE):
            with self._lock:
                for number in range(first, min(first + ONE_BY_ONE, len(listed))):
                    try:
                        pose = self._walk(None, target, source, listed[number])
                    except (ExtrapolationException, ConnectivityException) as exc:
                        if strict:
                            raise type(exc)(f'times[{number}]: {exc}') from None
                        if isinstance(exc, ConnectivityException):
                            apart = apart or exc
                        continue
                    translations[number] = pose[:3]
                    rotations[number] = pose[3:]
        if apart is not None and np.isnan(translations).all():
            raise apart
        return translations, rotations

    def stamps(self, target_frame: str, source_frame: str) -> Stamps:
        """Every stamp (int64 ns) at which a moving edge of the chain has a transform and the
        whole chain is covered, sorted: where the chain's transform changes."""
        target = clean_frame(target_frame, 'target_frame')
        source = clean_frame(source_frame, 'source_frame')
        with self._lock:
            if target == source:
                return np.zeros(0, dtype=np.int64)
            chain = self._tree.fixed_chain(target, source)
            if chain is None:  # through a frame that changed parent: every edge it may take
                edges = self._tree.reachable((target, source))
                moving = [edge.stamps.copy() for edge in edges if not edge.static]
            else:
                moving = [edge.stamps.copy() for _, edge in chain.moving]
        if chain is None and moving:  # the stamps at which a lookup succeeds
            candidates = np.unique(np.concatenate(moving))
            translations, _ = self._one_by_one(target, source, candidates, strict=False)
            found: Stamps = candidates[~np.isnan(translations[:, 0])]
            return found
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
        transform = self.lookup_transform(
            target_frame, obj.header.frame_id, obj.header.stamp, timeout
        )
        return transform_stamped(obj, transform)

    def transform_full(
        self,
        obj: Message,
        target_frame: str,
        target_time: TimeLike,
        fixed_frame: str,
        timeout: TimeoutLike = None,
    ) -> Message:
        """``obj`` (as for :meth:`transform`), taken at its header's stamp, in
        ``target_frame`` at ``target_time``, through ``fixed_frame`` (a frame that does not
        move between the two times): :meth:`lookup_transform_full` applied."""
        transform = self.lookup_transform_full(
            target_frame, target_time, obj.header.frame_id, obj.header.stamp, fixed_frame, timeout
        )
        return transform_stamped(obj, transform)

    def transform_points(
        self,
        points: Floats,
        target_frame: str,
        source_frame: str,
        time: TimeLike,
        timeout: TimeoutLike = None,
    ) -> Floats:
        """Points ``(N, 3)`` given in ``source_frame`` at ``time``, in ``target_frame``."""
        array = np.asarray(points, dtype=np.float64)
        if array.ndim != 2 or array.shape[1] != 3:
            raise InvalidArgumentException(f'points must have shape (N, 3), not {array.shape}')
        target = clean_frame(target_frame, 'target_frame')
        source = clean_frame(source_frame, 'source_frame')
        stamp = nanoseconds(time)
        pose, _ = self._attempt(lambda: self._pose(target, source, stamp), timeout)
        moved: Floats = np.asarray(pose[:3]) + rotate(np.asarray(pose[3:])[None, :], array)
        return moved

    # --- what it holds ---------------------------------------------------------------------

    def chain(self, target_frame: str, source_frame: str) -> list[str]:
        """The frames a lookup walks from ``source_frame`` to ``target_frame``, both included
        (tf2's ``_chainAsVector``); Lookup or ConnectivityException as a lookup raises."""
        target = clean_frame(target_frame, 'target_frame')
        source = clean_frame(source_frame, 'source_frame')
        with self._lock:
            if target == source:
                self._tree.check_known(target, source)
                return [source]
            found = self._tree.chain(target, source)
        up = [frame for frame, _ in found.up]
        down = [frame for frame, _ in found.down]
        top = (found.up[-1][1] if found.up else found.down[-1][1]).parent
        return [*up, top, *reversed(down)]

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
                for frame, edge in sorted(self._tree.edges.items())
                if len(edge)
            ]

    def frames(self) -> set[str]:
        """Every frame the buffer knows."""
        with self._lock:
            return set(self._tree.names)

    def all_frames_as_string(self) -> str:
        """One line per frame with a parent, as tf2 writes it."""
        return frames_as_string(self.edges())

    def all_frames_as_yaml(self, current_time: TimeLike | None = None) -> str:
        """The frames as tf2's YAML (parent, broadcaster, rate, most recent and oldest
        transform, buffer length; the delay too when ``current_time`` is given)."""
        now = None if current_time is None else nanoseconds(current_time, 'current_time')
        return frames_as_yaml(self.edges(), now)

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
        stamps: Stamps,
        rows: Floats,
        *,
        authority: Authority,
        static: bool,
    ) -> int:
        """Add a batch of checked transforms of one edge; how many it refused."""
        with self._lock:
            edge = self._tree.edge_for(parent, child, int(stamps[-1]), authority, static)
            if edge is None:
                return len(stamps)
            repeated = edge.extend(stamps, rows)
            edge.authority = authority
            self._tree.changed()
            self._tree.inserted(child, edge)
        if repeated:
            message = checks.repeated_batch(repeated, child, parent, authority)
            self.rejections.report(checks.REPEATED_DATA, authority, child, message)
        return repeated

    def __repr__(self) -> str:
        window = 'all' if self.cache_time is None else f'{self.cache_time / _NS:g} s'
        return f'<zros.tf.Buffer {len(self._tree.names)} frames, cache {window}>'


def _outcome(attempt: Callable[[], object]) -> TransformException | None:
    """The TransformException ``attempt()`` raises, None when it returns. Its text is not read
    here: an unknown frame's names its closest frames only when read (costly with many)."""
    try:
        attempt()
    except TransformException as exc:
        return exc
    return None


def _debug(failure: TransformException | None, full: bool) -> bool | tuple[bool, str]:
    """What ``can_transform`` returns: whether it would succeed, or rclpy's debug tuple."""
    if not full:
        return failure is None
    return (True, '') if failure is None else (False, str(failure))

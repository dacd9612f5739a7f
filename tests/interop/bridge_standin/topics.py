"""Routes of the stand-in: the base class and the two topic routes (§4, §7).

Every route lives on the stand-in's main thread (created, announced, retired there); only the
data callbacks run elsewhere.
"""

from __future__ import annotations

import collections
import importlib
import logging
import threading
import time
from typing import TYPE_CHECKING, Any

import zenoh
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from zenoh import ext

from tests.interop.bridge_standin import protocol as p

if TYPE_CHECKING:
    from tests.interop.bridge_standin.runtime import StandIn

log = logging.getLogger('standin')

ECHO_WINDOW = 5.0  # seconds a sample written to DDS is remembered (see EchoFilter)
UNBOUNDED_CACHE = 1_000_000
VOLATILE_WRITER_ROOM = (
    100  # unacknowledged samples a volatile DDS writer keeps (see writer_profile)
)


# --- QoS between the token chunk and rclpy -------------------------------------------------------


def _durability(qos: p.TokenQos) -> DurabilityPolicy:
    if qos.durability in (None, p.VOLATILE):
        return DurabilityPolicy.VOLATILE
    return DurabilityPolicy.TRANSIENT_LOCAL  # rclpy has no TRANSIENT/PERSISTENT


def writer_profile(qos: p.TokenQos) -> QoSProfile:
    """The QoS of the DDS writer the bridge creates for an MP token (or a discovered reader).

    Unset policies take the DDS writer defaults (reliable, volatile, keep-last 1); a best-effort
    writer is made reliable, as the bridge does since its fix for issue #23.

    A volatile writer gets a depth of at least ``VOLATILE_WRITER_ROOM``. The real bridge's
    CycloneDDS keeps a reliable writer's unacknowledged samples whatever its keep-last depth (it
    throttles the writer instead), while the stand-in's Fast DDS drops the oldest one at that
    depth: two 900 KB images written back to back through a keep-last-1 writer lost the first
    under load. Depth only says what a late reader gets for a transient-local writer, so it stays.
    """
    if qos.history == p.KEEP_ALL:
        return QoSProfile(
            history=HistoryPolicy.KEEP_ALL,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=_durability(qos),
        )
    depth = qos.depth if qos.history is not None and qos.depth else 1
    if qos.durability in (None, p.VOLATILE):
        depth = max(depth, VOLATILE_WRITER_ROOM)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=_durability(qos),
    )


def reader_profile(qos: p.TokenQos) -> QoSProfile:
    """The QoS of the DDS reader the bridge creates for an MS token (or a discovered writer).

    Unset policies take the DDS reader defaults (best-effort, volatile). For an unset history
    the stand-in keeps 10 samples, not DDS's 1: its Python callbacks are slower than the real
    bridge's and would otherwise lose samples of a burst.
    """
    reliability = (
        ReliabilityPolicy.RELIABLE
        if qos.reliability == p.RELIABLE
        else ReliabilityPolicy.BEST_EFFORT
    )
    if qos.history == p.KEEP_ALL:
        return QoSProfile(
            history=HistoryPolicy.KEEP_ALL, reliability=reliability, durability=_durability(qos)
        )
    depth = qos.depth if qos.history is not None and qos.depth else 10
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=reliability,
        durability=_durability(qos),
    )


def endpoint_qos(profile: QoSProfile, type_hash: Any = None) -> p.TokenQos:
    """The token QoS of a discovered ROS endpoint.

    DDS discovery carries reliability and durability but not history (rclpy reports UNKNOWN,
    depth 0), so the history field stays unset. A Jazzy bridge adds the endpoint's type hash
    (``typehash=RIHS01_...;``, from the DDS user data; here rclpy's ``TypeHash``).
    """
    reliability = {
        ReliabilityPolicy.RELIABLE: p.RELIABLE,
        ReliabilityPolicy.BEST_EFFORT: p.BEST_EFFORT,
    }.get(profile.reliability)
    durability = {
        DurabilityPolicy.TRANSIENT_LOCAL: p.TRANSIENT_LOCAL,
        DurabilityPolicy.VOLATILE: p.VOLATILE,
    }.get(profile.durability)
    history = depth = None
    if profile.history == HistoryPolicy.KEEP_LAST and profile.depth > 0:
        history, depth = p.KEEP_LAST, profile.depth
    elif profile.history == HistoryPolicy.KEEP_ALL:
        history, depth = p.KEEP_ALL, profile.depth
    user_data = None
    if type_hash is not None and type_hash.version == 1:
        user_data = f'typehash=RIHS01_{bytes(type_hash.value).hex()};'
    return p.TokenQos(False, reliability, durability, history, depth, user_data)


def interface_class(type_name: str) -> Any:
    """The rclpy class of ``pkg/msg|srv|action/Name``, or of an action's derived types
    (``pkg/action/Name_SendGoal``, ``_GetResult``, ``_FeedbackMessage``)."""
    package, kind, short = type_name.split('/')
    module = importlib.import_module(f'{package}.{kind}')
    if kind == 'action':
        for suffix, attribute in (
            ('_SendGoal', 'SendGoalService'),
            ('_GetResult', 'GetResultService'),
            ('_FeedbackMessage', 'FeedbackMessage'),
        ):
            if short.endswith(suffix):
                return getattr(getattr(module, short[: -len(suffix)]).Impl, attribute)
    return getattr(module, short)


class EchoFilter:
    """Stands in for CycloneDDS's ignore-local: drops the samples the bridge wrote itself.

    rclpy exposes neither ``ignore_local_publications`` nor the writer of a sample, so a raw
    reader of the stand-in receives what the stand-in's own writer on the same topic wrote. The
    filter remembers a hash of every payload written to DDS for a few seconds; a sample read back
    with the same hash is consumed as an echo. A ROS node sending byte-identical data on the same
    topic within that window would be dropped once: tests avoid that.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._recent: dict[str, collections.deque[tuple[float, int]]] = {}

    def wrote(self, ros_name: str, data: bytes) -> None:
        with self._lock:
            recent = self._recent.setdefault(ros_name, collections.deque(maxlen=1000))
            recent.append((time.monotonic(), hash(data)))

    def is_echo(self, ros_name: str, data: bytes) -> bool:
        with self._lock:
            recent = self._recent.get(ros_name)
            if not recent:
                return False
            limit = time.monotonic() - ECHO_WINDOW
            while recent and recent[0][0] < limit:
                recent.popleft()
            digest = hash(data)
            for index, (_, seen) in enumerate(recent):
                if seen == digest:
                    del recent[index]
                    return True
        return False


# --- routes -------------------------------------------------------------------------------------


class Route:
    """What every route shares: a ROS name, its key, type and QoS, and who needs it.

    ``remote_routes`` holds the ``"<zid>:<ke>"`` of the tokens that asked for the route,
    ``local_nodes`` the local ROS endpoints (their token QoS) it serves. A route announces its
    ``token_kind`` token while it has local endpoints, and is retired when it has neither.
    Parts of an action route are routes with ``announce=False``.
    """

    admin_kind = ''
    token_kind = p.Kind.MP

    def __init__(
        self,
        bridge: StandIn,
        ros_name: str,
        type_name: str,
        qos: p.TokenQos | None = None,
        *,
        key: str | None = None,
        announce: bool = True,
    ) -> None:
        self.bridge = bridge
        self.ros_name = ros_name
        self.type_name = type_name
        self.qos = qos or p.TokenQos()
        self.key = key or p.ros_to_key(ros_name, bridge.options.namespace)
        self.announce = announce
        self.remote_routes: set[str] = set()
        self.local_nodes: dict[str, p.TokenQos] = {}
        self.token: Any = None
        self.lock = threading.Lock()
        self.closed = False

    @property
    def needed(self) -> bool:
        return bool(self.remote_routes or self.local_nodes)

    def set_local(self, endpoints: dict[str, p.TokenQos]) -> None:
        """The local ROS endpoints the graph now shows; announces or retires the route's token."""
        self.local_nodes = endpoints
        if not self.announce:
            return
        if endpoints and self.token is None:
            qos = self.qos if self.token_kind.has_qos else None
            token = p.Token(self.bridge.zid, self.token_kind, self.key, self.type_name, qos)
            self.token = self.bridge.session.liveliness().declare_token(token.to_key())
        elif not endpoints and self.token is not None:
            self.token.undeclare()
            self.token = None

    def update(self) -> None:
        """Re-check what depends on the DDS graph (called after every graph poll)."""

    @property
    def active(self) -> bool:
        raise NotImplementedError

    def admin(self) -> dict[str, Any]:
        return {
            'ros2_name': self.ros_name,
            'ros2_type': self.type_name,
            'zenoh_key_expr': self.key,
            'remote_routes': sorted(self.remote_routes),
            'local_nodes': sorted(self.local_nodes),
            'is_active': self.active,
        }

    def close(self) -> None:
        self.closed = True
        if self.token is not None:
            self.token.undeclare()
            self.token = None


class RoutePublisher(Route):
    """DDS -> Zenoh (a ROS publisher, or an MS token): a Zenoh publisher on the key, fed by a DDS
    reader that exists only while some remote Zenoh subscriber matches the key (§4)."""

    admin_kind = 'topic/pub'
    token_kind = p.Kind.MP

    def __init__(
        self,
        bridge: StandIn,
        ros_name: str,
        type_name: str,
        qos: p.TokenQos | None = None,
        **options: Any,
    ) -> None:
        super().__init__(bridge, ros_name, type_name, qos, **options)
        self.msg_class = interface_class(type_name)
        qos = self.qos
        session = bridge.session
        reliable = qos.reliability == p.RELIABLE
        congestion = zenoh.CongestionControl.BLOCK if reliable else zenoh.CongestionControl.DROP
        remote = zenoh.Locality.REMOTE
        self.cache_size = 0
        if qos.durability not in (None, p.VOLATILE):
            # 1.5.1+: a zenoh-ext AdvancedPublisher with a cache of depth x multiplier (§7)
            if qos.history == p.KEEP_ALL:
                self.cache_size = UNBOUNDED_CACHE
            else:
                depth = qos.depth if qos.history is not None and qos.depth else 1
                self.cache_size = depth * bridge.options.cache_multiplier
            self.publisher: Any = ext.declare_advanced_publisher(
                session,
                self.key,
                cache=ext.CacheConfig(max_samples=self.cache_size),
                publisher_detection=True,
                congestion_control=congestion,
                allowed_destination=remote,
            )
            # the advanced publisher has no matching listener in Python: a plain publisher on
            # the same key that never puts watches the subscribers instead
            self.probe: Any = session.declare_publisher(self.key, allowed_destination=remote)
        else:
            self.publisher = session.declare_publisher(
                self.key, congestion_control=congestion, allowed_destination=remote
            )
            self.probe = self.publisher
        self.listener = self.probe.declare_matching_listener(
            lambda _status: bridge.post(self.update)
        )
        self.reader: Any = None
        self.update()

    @property
    def active(self) -> bool:
        return self.reader is not None

    def update(self) -> None:
        """Create the DDS reader while remote Zenoh subscribers match, delete it when none does."""
        if self.closed:
            return
        matching = self.probe.matching_status.matching
        if matching and self.reader is None:
            self.reader = self.bridge.node.create_subscription(
                self.msg_class, self.ros_name, self.on_dds, reader_profile(self.qos), raw=True
            )
            log.info('route %s: DDS reader created', self.ros_name)
        elif not matching and self.reader is not None:
            self.bridge.node.destroy_subscription(self.reader)
            self.reader = None
            log.info('route %s: DDS reader deleted', self.ros_name)

    def on_dds(self, data: bytes) -> None:
        if self.closed or self.bridge.echo.is_echo(self.ros_name, data):
            return
        self.publisher.put(data)  # verbatim: CDR header included, no encoding, no attachment

    def admin(self) -> dict[str, Any]:
        info = super().admin()
        info['qos'] = self.qos.to_chunk()
        info['publication_cache_size'] = self.cache_size
        return info

    def close(self) -> None:
        super().close()
        self.listener.undeclare()
        if self.reader is not None:
            self.bridge.node.destroy_subscription(self.reader)
            self.reader = None
        if self.probe is not self.publisher:
            self.probe.undeclare()
        self.publisher.undeclare()


class RouteSubscriber(Route):
    """Zenoh -> DDS (a ROS subscriber, or an MP token): a DDS writer from the start, fed by a Zenoh
    subscriber that exists only while a local ROS subscriber exists (§4).

    The stand-in also waits until its writer has matched that subscriber, so that nothing is
    lost between rclpy's graph showing the reader and the DDS match (CycloneDDS does both at
    once in the real bridge). Parts of action routes (``announce=False``) activate as soon as
    their writer has matched any reader.
    """

    admin_kind = 'topic/sub'
    token_kind = p.Kind.MS

    def __init__(
        self,
        bridge: StandIn,
        ros_name: str,
        type_name: str,
        qos: p.TokenQos | None = None,
        **options: Any,
    ) -> None:
        super().__init__(bridge, ros_name, type_name, qos, **options)
        self.msg_class = interface_class(type_name)
        self.writer = bridge.node.create_publisher(
            self.msg_class, ros_name, writer_profile(self.qos)
        )
        self.subscriber: Any = None

    @property
    def active(self) -> bool:
        return self.subscriber is not None

    @property
    def transient_local(self) -> bool:
        return self.qos.durability not in (None, p.VOLATILE)

    def update(self) -> None:
        if self.closed:
            return
        readers = self.writer.get_subscription_count()
        wanted = readers > 0 and (bool(self.local_nodes) or not self.announce)
        if wanted and self.subscriber is None:
            session = self.bridge.session
            if self.transient_local:
                # 1.5.1+: query the history of AdvancedPublishers (late joiners too), §7
                depth = self.qos.depth if self.qos.history == p.KEEP_LAST and self.qos.depth else 1
                self.subscriber = ext.declare_advanced_subscriber(
                    session,
                    self.key,
                    self.on_zenoh,
                    allowed_origin=zenoh.Locality.REMOTE,
                    history=ext.HistoryConfig(detect_late_publishers=True, max_samples=depth),
                )
            else:
                self.subscriber = session.declare_subscriber(
                    self.key, self.on_zenoh, allowed_origin=zenoh.Locality.REMOTE
                )
            log.info('route %s: Zenoh subscriber declared', self.ros_name)
        elif self.subscriber is not None and not (self.local_nodes or not self.announce):
            self.subscriber.undeclare()
            self.subscriber = None
            log.info('route %s: Zenoh subscriber undeclared', self.ros_name)

    def on_zenoh(self, sample: Any) -> None:
        data = sample.payload.to_bytes()
        # the bridge checks nothing on topic payloads: CycloneDDS gets them verbatim
        with self.lock:
            if self.closed:
                return
            self.bridge.echo.wrote(self.ros_name, data)
            self.writer.publish(data)

    def admin(self) -> dict[str, Any]:
        info = super().admin()
        info['qos'] = self.qos.to_chunk()
        return info

    def close(self) -> None:
        super().close()
        if self.subscriber is not None:
            self.subscriber.undeclare()
            self.subscriber = None
        with self.lock:
            self.closed = True
            self.bridge.node.destroy_publisher(self.writer)

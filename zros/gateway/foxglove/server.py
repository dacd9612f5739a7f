"""``zros foxglove``: the ROS graph reached over Zenoh, served to the Foxglove app.

A zros node follows the graph; each topic becomes a channel of the Foxglove SDK's WebSocket
server with its ``ros2msg`` schema (with its dependencies, as in rosbag2's MCAP files) and
``cdr`` encoding. A topic gets a Zenoh subscription, with its publishers' QoS, only while a
client watches it (:class:`~zros.gateway.common.watched_topics.Taps`); its CDR bytes go to
the SDK undecoded.
Clients also publish (``clientPublish``), call services, get, set and follow parameters, see
the connection graph, fetch ``package://`` assets and, with ``/clock``, follow sim time.

The Python SDK cannot send to one client only: a client that starts watching a latched topic
others watch makes the kept latched messages go to every watcher again, so only shallow latched
topics (state such as ``/tf_static``) are kept."""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from zros.closing import Closing
from zros.errors import ZrosError
from zros.gateway.common.entities import start_gateway
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import NameFilter
from zros.gateway.common.graph_watcher import GraphWatcher
from zros.gateway.common.limits import CLIENT_BUFFER, FOXGLOVE_PORT, MAX_CLIENTS
from zros.gateway.common.origins import FOXGLOVE_APP
from zros.gateway.common.throttle import Throttle
from zros.gateway.common.views import offered_services, owners, parameter_nodes, service_providers
from zros.gateway.common.watched_topics import Taps
from zros.gateway.foxglove.assets import Assets
from zros.gateway.foxglove.calls import ENCODINGS, ClientChannels, ServiceOffer
from zros.gateway.foxglove.params import Parameters
from zros.gateway.foxglove.sdk import (
    DEFAULT_BACKLOG,
    ServerOptions,
    connection_graph,
    import_sdk,
    ros2msg_schema,
)
from zros.gateway.foxglove.sdk_listener import Listener
from zros.gateway.foxglove.sim_time import follow_clock
from zros.pubsub.taps import GraphTopic, RawTap, graph_topics, is_hidden
from zros.qos import QoS

if TYPE_CHECKING:
    import foxglove
    from foxglove.websocket import ClientChannel, Parameter
    from typing_extensions import Unpack

    from zros.gateway.foxglove.bag_server import BagGateway
    from zros.node import Node
    from zros.node.settings import NodeKeywords

_log = logging.getLogger('zros.gateway')

#: seconds the gateway gives the graph to show ``/clock`` when deciding on sim time
SIM_TIME_DISCOVERY = 1.0


@dataclass
class _Channel:
    channel: foxglove.Channel
    topic: GraphTopic


class FoxgloveGateway(Closing):
    """A Foxglove WebSocket server showing the graph ``node`` sees (see the module docstring).

    ``topics`` and ``exclude`` are regular expressions of topic names (whole names; every
    topic when ``topics`` is empty), ``services`` and ``params`` those of the services and
    parameters (``/node.name``) offered; hidden names (``/_x``) only with ``include_hidden``.
    ``asset_paths`` are the folders ``package://`` URIs are served from. ``sim_time`` makes the
    server publish ``/clock`` as its time (None: when ``/clock`` has a publisher at the start).
    ``read_only``: clients only watch (no publishing, service calls or parameter sets); else
    they publish only on topics ``topics`` and ``exclude`` select.
    ``own_node``: the gateway made ``node`` and destroys it on :meth:`close`.
    """

    def __init__(
        self,
        node: Node,
        options: ServerOptions | None = None,
        *,
        topics: Iterable[str] | None = None,
        exclude: Iterable[str] | None = None,
        services: Iterable[str] | None = None,
        params: Iterable[str] | None = None,
        include_hidden: bool = False,
        asset_paths: Iterable[str | os.PathLike[str]] = (),
        sim_time: bool | None = None,
        read_only: bool = False,
        own_node: bool = False,
        throttle: Iterable[str] = (),
    ) -> None:
        foxglove = import_sdk()
        from foxglove.websocket import Capability  # noqa: PLC0415 (optional: the foxglove extra)

        self.node = node
        self.options = options or ServerOptions()
        self._own_node = own_node
        self.read_only = read_only
        self._topics = NameFilter.regexes(topics, exclude)
        self._include_hidden = include_hidden
        self._assets = Assets(asset_paths) if asset_paths else None
        self._lock = threading.Lock()
        self._channels: dict[str, _Channel] = {}
        self._names: dict[int, str] = {}  # channel id -> topic
        self._graph_published: object = None
        self._closed = False
        if sim_time is None:
            node.graph.refresh(SIM_TIME_DISCOVERY)
            sim_time = '/clock' in graph_topics(node)
        self.sim_time = sim_time
        self._sim_now = 0
        self._taps = Taps(node, self.now, limit=Throttle.parse(throttle).limit)
        self._context = foxglove.Context()
        capabilities = [Capability.Parameters, Capability.ConnectionGraph]
        if not read_only:
            capabilities += [Capability.ClientPublish, Capability.Services]
        if sim_time:
            capabilities.append(Capability.Time)
        self._server, self._front = self.options.start(
            capabilities=capabilities,
            server_listener=Listener(self),
            supported_encodings=list(ENCODINGS),
            asset_handler=self._assets.fetch if self._assets is not None else None,
            context=self._context,
        )
        self.port: int = self._front.port
        self.url = self.options.url(self.port)
        self.clients = ClientChannels(node, self._offered_qos, self.status)
        self.services = ServiceOffer(node, self._server, NameFilter.regexes(services))
        self.parameters = Parameters(
            node,
            NameFilter.regexes(params),
            lambda: parameter_nodes(self._all_services()),
            self._server.publish_parameter_values,
            self.status,
        )
        self._clock: RawTap | None = None
        if sim_time:
            self._clock = follow_clock(node, self._on_clock)
        self._watcher = GraphWatcher(node, self._follow_graph)
        _log.info(
            'Foxglove server on %s (%s wire%s)',
            self.url,
            node.wire,
            ', read-only' if read_only else '',
        )

    # --- time --------------------------------------------------------------------------------

    def now(self) -> int:
        """The server's time in ns: ``/clock`` under sim time, else the wall clock."""
        return self._sim_now if self.sim_time else time.time_ns()

    def _on_clock(self, now: int) -> None:
        self._sim_now = now
        self._server.broadcast_time(now)

    # --- the graph ---------------------------------------------------------------------------

    def _wanted(self, name: str) -> bool:
        return (self._include_hidden or not is_hidden(name)) and self._topics(name)

    def _all_services(self) -> dict[str, str]:
        return offered_services(
            self.node, exclude_node=self.node.fully_qualified_name, include_hidden=True
        )

    def _follow_graph(self) -> None:
        if self._closed:
            return
        own = self.node.fully_qualified_name
        topics = {
            name: topic
            for name, topic in graph_topics(
                self.node, publishers_only=False, exclude_node=own
            ).items()
            if self._wanted(name)
        }
        self._update_channels(topics)
        services = {} if self.read_only else self._all_services()
        self.services.update(
            {n: t for n, t in services.items() if self._include_hidden or not is_hidden(n)}
        )
        self._publish_connection_graph(topics)

    def _update_channels(self, topics: dict[str, GraphTopic]) -> None:
        import foxglove  # noqa: PLC0415 (optional: the foxglove extra)

        gone: list[_Channel] = []
        with self._lock:
            for name, known in list(self._channels.items()):
                topic = topics.get(name)
                if topic is None or topic.type_name != known.topic.type_name:
                    gone.append(self._channels.pop(name))
                    self._names.pop(known.channel.id(), None)
                else:
                    known.topic = topic
            new = [topic for name, topic in topics.items() if name not in self._channels]
        for item in gone:  # outside the lock: closing calls on_unsubscribe back
            item.channel.close()
            self._taps.drop(item.topic.name)
            _log.info('channel %s closed', item.topic.name)
        for topic in new:
            schema = ros2msg_schema(self.node.registry, topic.type_name)
            with self._lock:  # a client may subscribe as soon as the channel is advertised
                channel = foxglove.Channel(
                    topic.name, schema=schema, message_encoding='cdr', context=self._context
                )
                self._channels[topic.name] = _Channel(channel, topic)
                self._names[channel.id()] = topic.name
            _log.info('channel %s [%s]', topic.name, topic.type_name)

    def _offered_qos(self, topic: str) -> list[QoS]:
        try:
            name = self.node.resolve_name(topic)
        except ZrosError:  # an invalid name: the publisher refuses it, with the reason
            return []
        with self._lock:
            known = self._channels.get(name)
            return known.topic.offered if known is not None else []

    def _publish_connection_graph(self, topics: dict[str, GraphTopic]) -> None:
        graph = self.node.graph
        published = {name: owners(t.publishers, graph) for name, t in topics.items()}
        subscribed = {name: owners(t.subscribers, graph) for name, t in topics.items()}
        providers = service_providers(self.node, self.services.offered)
        view = (published, subscribed, providers)
        if view == self._graph_published:
            return
        self._server.publish_connection_graph(connection_graph(*view))
        self._graph_published = view

    # --- clients acting on the graph -----------------------------------------------------------

    def advertise(self, client: int, channel: ClientChannel) -> None:
        """A client announced a channel: its publisher, if this gateway lets clients publish
        there (GatewayError says why not)."""
        if self.read_only:
            raise GatewayError(f'{channel.topic}: this server is read-only')
        try:
            name = self.node.resolve_name(channel.topic)
        except ZrosError:  # an invalid name: the publisher refuses it, with the reason
            name = channel.topic
        if not self._wanted(name):
            raise GatewayError(f'{channel.topic}: not among the topics this server offers')
        self.clients.advertise(client, channel)

    def set_parameters(self, parameters: list[Parameter]) -> list[Parameter]:
        """Set parameters (refused when read-only: their values as they are)."""
        if self.read_only:
            self.status('parameters may not be set: this server is read-only', 'error')
            return self.parameters.get([p.name for p in parameters])
        return self.parameters.set(parameters)

    # --- watching ----------------------------------------------------------------------------

    def watch(self, client: int, channel_id: int) -> None:
        """A client subscribed to a channel: tap its topic (first watcher), or replay the kept
        latched messages a new watcher of a latched topic would miss."""
        with self._lock:
            name = self._names.get(channel_id)
            known = self._channels.get(name) if name is not None else None
        if known is None:
            return
        log = known.channel.base.log
        latched = self._taps.watch(known.topic, client, log)
        for data, stamp in latched:
            log(data, stamp)
        with self._lock:
            still = self._channels.get(known.topic.name) is known
        if not still:  # the topic left the graph meanwhile
            self._taps.drop(known.topic.name)

    def unwatch(self, client: int, channel_id: int) -> None:
        """A client unsubscribed (or left): the last one out releases the topic."""
        with self._lock:
            name = self._names.get(channel_id)
        if name is not None:
            self._taps.unwatch(name, client)

    # --- the user's side -----------------------------------------------------------------------

    def status(self, text: str, level: str = 'warning') -> None:
        """Tell every client something (a status message, and a log line here)."""
        import foxglove  # noqa: PLC0415 (optional: the foxglove extra)

        levels = {
            'info': foxglove.StatusLevel.Info,
            'warning': foxglove.StatusLevel.Warning,
            'error': foxglove.StatusLevel.Error,
        }
        _log.log(logging.INFO if level == 'info' else logging.WARNING, '%s', text)
        if not self._closed:
            self._server.publish_status(text, levels[level])

    @property
    def channels(self) -> dict[str, str]:
        """The topics offered as channels, and their types."""
        with self._lock:
            return {name: c.topic.type_name for name, c in self._channels.items()}

    def watched(self) -> dict[str, int]:
        """The topics with a Zenoh subscription now, and how many clients watch each."""
        return self._taps.watched()

    def forwarded(self, topic: str) -> tuple[int, int]:
        """Messages and bytes received on a watched topic so far."""
        return self._taps.counts(topic)

    @property
    def slow_client_reports(self) -> int:
        """How many warnings slow clients got (their oldest messages dropped)."""
        return self._front.reported

    @property
    def dropped(self) -> int:
        """Messages dropped so far for clients that did not read fast enough."""
        return self._front.dropped

    def close(self) -> None:
        """Stop the server and release every Zenoh entity (and the node, if the gateway made
        it)."""
        if self._closed:
            return
        self._closed = True
        self._watcher.close()
        self._front.close()
        self._server.stop()
        if self._clock is not None:
            self._clock.close()
        self._taps.close()
        self.parameters.close()
        self.clients.close()
        self.services.close()
        with self._lock:
            channels, self._channels = list(self._channels.values()), {}
        for item in channels:
            item.channel.close()
        if self._own_node:
            self.node.destroy()

    def __repr__(self) -> str:
        return f'<zros FoxgloveGateway {self.url} ({len(self._channels)} channels)>'


def serve(
    *,
    port: int = FOXGLOVE_PORT,
    address: str = '127.0.0.1',
    topics: Iterable[str] | None = None,
    exclude: Iterable[str] | None = None,
    services: Iterable[str] | None = None,
    params: Iterable[str] | None = None,
    include_hidden: bool = False,
    asset_paths: Iterable[str | os.PathLike[str]] = (),
    bag: str | os.PathLike[str] | None = None,
    tls_cert: str | os.PathLike[str] | None = None,
    tls_key: str | os.PathLike[str] | None = None,
    message_backlog: int = DEFAULT_BACKLOG,
    client_buffer: int = CLIENT_BUFFER,
    max_clients: int = MAX_CLIENTS,
    allow_origins: Iterable[str] = (FOXGLOVE_APP,),
    read_only: bool = False,
    sim_time: bool | None = None,
    node: Node | None = None,
    name: str = 'zros_foxglove',
    throttle: Iterable[str] = (),
    **settings: Unpack[NodeKeywords],
) -> FoxgloveGateway | BagGateway:
    """Serve the robot (or, with ``bag``, a recording) to Foxglove at
    ``ws://address:port``; returns the running server (``close()`` it, or use ``with``).

    Browsers connect from pages of this machine and of ``allow_origins`` (the Foxglove web
    app's by default; ``'*'``: any page); programs (no ``Origin``) always. Each client may have
    ``client_buffer`` bytes queued before its oldest messages are dropped; at most
    ``max_clients`` are served at once (others get HTTP 503). ``read_only``: clients only watch.

    Without ``node``, a node named ``name`` joins the graph with the connection ``settings``
    of :class:`zros.Node` (``connect``, ``wire``, ``transport``, ``tls``...). ``throttle``:
    ``REGEX=HZ`` rate limits of live topics (:mod:`zros.gateway.common.throttle`).
    """
    options = ServerOptions(
        port=port,
        address=address,
        tls_cert=tls_cert,
        tls_key=tls_key,
        message_backlog=message_backlog,
        name='zros',
        allow_origins=tuple(allow_origins),
        client_buffer=client_buffer,
        max_clients=max_clients,
    )
    if bag is not None:
        from zros.gateway.foxglove.bag_server import BagGateway  # noqa: PLC0415 (loaded only to play a bag)

        return BagGateway(bag, options, topics=topics, exclude=exclude, asset_paths=asset_paths)
    return start_gateway(node, name, settings, lambda node, own: FoxgloveGateway(
        node,
        options,
        topics=topics,
        exclude=exclude,
        services=services,
        params=params,
        include_hidden=include_hidden,
        asset_paths=asset_paths,
        sim_time=sim_time,
        read_only=read_only,
        own_node=own,
        throttle=throttle,
    ))  # fmt: skip

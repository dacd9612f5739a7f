"""Foxglove clients acting on the ROS graph: publishing (client channels) and calling services.

A client channel (Teleop's Twist, a Publish panel) becomes a zros publisher on its topic, with
the QoS of the topic's other publishers (ROS 2's default without), sending CDR as it comes
(checked first: bad bytes never reach the graph) or JSON converted to CDR. A type other than
the one the topic's endpoints use is refused (any type goes on a topic without endpoints).
Every service with a server on the graph is offered with its request and response schemas; a
call goes through a zros service client.
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from zros.cdr import CdrError, TypeRegistry
from zros.cdr.message import decode, encode
from zros.errors import ZrosError
from zros.gateway.common.entities import ClientCache, publisher_qos
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import NameFilter
from zros.gateway.foxglove.sdk import ros2msg_schema
from zros.pubsub import Publisher
from zros.qos import QoS

if TYPE_CHECKING:
    import foxglove
    from foxglove.websocket import ClientChannel, ServiceRequest, WebSocketServer

    from zros.cdr import Message
    from zros.node import Node
    from zros.services import Client

_log = logging.getLogger('zros.gateway')

#: the message encodings a Foxglove client may publish in (service calls: the CDR of each
#: service's request schema, which the SDK holds the client to)
ENCODINGS = ('cdr', 'json')
#: seconds a service call through the gateway may take
SERVICE_TIMEOUT = 10.0
#: channels one client may advertise at once (each is a publisher the whole graph sees)
MAX_CHANNELS = 1000


@dataclass
class _Advertised:
    topic: str
    encoding: str
    cls: type[Message]
    publisher: Publisher[Message]
    bad: int = 0  #: messages refused


class ClientChannels:
    """The topics Foxglove clients publish on. ``status(text)`` tells the clients what went
    wrong (a type no one knows, a message that does not decode)."""

    def __init__(
        self,
        node: Node,
        offered_qos: Callable[[str], list[QoS]],
        status: Callable[[str], object],
    ) -> None:
        self._node = node
        self._offered_qos = offered_qos
        self._status = status
        self._lock = threading.Lock()
        self._channels: dict[tuple[int, int], _Advertised] = {}

    def advertise(self, client: int, channel: ClientChannel) -> None:
        """A client announced a channel (the SDK's ``ClientChannel``): make its publisher
        (GatewayError says why not)."""
        topic, encoding, type_name = channel.topic, channel.encoding, channel.schema_name
        schema_encoding, schema = channel.schema_encoding, channel.schema
        with self._lock:
            held = sum(owner == client for owner, _ in self._channels)
            if (client, channel.id) not in self._channels and held >= MAX_CHANNELS:
                raise GatewayError(
                    f'{topic}: a client may advertise at most {MAX_CHANNELS} channels at once'
                )
        if encoding not in ENCODINGS:
            raise GatewayError(f'{topic}: the encoding {encoding!r} is not one of {ENCODINGS}')
        try:
            cls = self._node.registry.get_class(type_name)
        except ZrosError as exc:
            if schema_encoding != 'ros2msg' or not schema:
                raise GatewayError(
                    f'{topic}: unknown type {type_name} and no ros2msg schema'
                ) from exc
            cls = self._client_type(topic, type_name, schema)
        self._check_type(topic, cls.__msgtype__)
        qos = publisher_qos(self._offered_qos(topic))
        try:
            publisher = Publisher(topic, cls, qos, node=self._node)
        except (ZrosError, ValueError) as exc:
            raise GatewayError(f'cannot publish on {topic}: {exc}') from None
        with self._lock:
            previous = self._channels.pop((client, channel.id), None)
            self._channels[client, channel.id] = _Advertised(
                publisher.topic, encoding, cls, publisher
            )
        if previous is not None:
            previous.publisher.close()
        _log.info('client %d publishes %s [%s] in %s', client, publisher.topic, type_name, encoding)

    def _check_type(self, topic: str, type_name: str) -> None:
        """Refuse a type other than the one the graph's endpoints on ``topic`` use (a bridge
        to DDS keys by topic name only: its ROS nodes would get bytes of the wrong type). A
        topic without endpoints takes any type."""
        try:
            name = self._node.resolve_name(topic)
        except ZrosError:  # an invalid name: the publisher refuses it, with the reason
            return
        known = dict(self._node.get_topic_names_and_types()).get(name, [])
        if known and type_name not in known:
            raise GatewayError(
                f'{name}: refused to publish {type_name}, the topic has type {", ".join(known)}'
            )

    def _client_type(self, topic: str, type_name: str, schema: bytes) -> type[Message]:
        """The class of a type only a client's schema defines, in a registry of the clients'
        own (never the node's, which the process shares)."""
        registry = TypeRegistry(self._node.registry.distro)
        try:
            registry.register_bundle(type_name, schema.decode(), f'a Foxglove client ({topic})')
            return registry.get_class(type_name)
        except (ZrosError, UnicodeDecodeError) as exc:
            raise GatewayError(f'{topic}: the schema of {type_name} is unusable: {exc}') from None

    def unadvertise(self, client: int, channel: int) -> None:
        """A client withdrew a channel (or left)."""
        with self._lock:
            advertised = self._channels.pop((client, channel), None)
        if advertised is not None:
            advertised.publisher.close()

    def message(self, client: int, channel: int, data: bytes) -> None:
        """Publish what a client sent on one of its channels."""
        advertised = self._channels.get((client, channel))
        if advertised is None:
            return  # the SDK refuses data on channels a client never advertised
        try:
            if advertised.encoding == 'cdr':
                decode(advertised.cls, data)
                advertised.publisher.write_raw(data)
            else:
                advertised.publisher.write(message_from_json(advertised.cls, data))
        except (CdrError, GatewayError, ValueError, TypeError) as exc:
            advertised.bad += 1
            if advertised.bad == 1:  # once per channel: a client may send thousands
                self._status(
                    f'a message on {advertised.topic} was not published '
                    f'(reported once per channel): {exc}'
                )

    def close(self) -> None:
        """Close every publisher."""
        with self._lock:
            advertised, self._channels = list(self._channels.values()), {}
        for item in advertised:
            item.publisher.close()


class ServiceOffer:
    """The services of the graph, offered to Foxglove clients through the SDK's server."""

    def __init__(self, node: Node, server: WebSocketServer, allowed: NameFilter) -> None:
        self._node = node
        self._server = server
        self._allowed = allowed
        self._offered: dict[str, str] = {}  # name -> type
        self._clients: ClientCache[Client] = ClientCache()

    def update(self, services: dict[str, str]) -> None:
        """Offer the services of ``services`` (name -> type) and withdraw the others."""
        wanted = {name: t for name, t in services.items() if self._allowed(name)}
        gone = [n for n, t in self._offered.items() if wanted.get(n) != t]
        if gone:
            self._server.remove_services(gone)
            for name in gone:
                del self._offered[name]
                self._clients.discard(name)
        added = [self._service(n, t) for n, t in wanted.items() if n not in self._offered]
        added_services = [service for service in added if service is not None]
        if added_services:
            self._server.add_services(added_services)
            self._offered.update({s.name: wanted[s.name] for s in added_services})

    def _service(self, name: str, type_name: str) -> foxglove.Service | None:
        import foxglove  # noqa: PLC0415 (optional: the foxglove extra)

        registry = self._node.registry
        schemas = []
        for part in ('_Request', '_Response'):
            schema = ros2msg_schema(registry, type_name + part)
            if schema is None:
                return None  # zros cannot call a service whose type it does not know
            schemas.append(foxglove.MessageSchema(encoding='cdr', schema=schema))
        return foxglove.Service(
            name,
            schema=foxglove.ServiceSchema(type_name, request=schemas[0], response=schemas[1]),
            handler=self._handler(name, type_name),
        )

    def _client(self, name: str, type_name: str) -> Client:
        client: Client = self._clients.get(
            name, lambda: self._node.create_client(type_name, name, SERVICE_TIMEOUT)
        )
        return client

    def _handler(self, name: str, type_name: str) -> Callable[[ServiceRequest], bytes]:
        def handle(request: ServiceRequest) -> bytes:
            client = self._client(name, type_name)
            # CDR only: the SDK refuses a call in another encoding than the request schema's
            try:
                message = decode(client.Request, request.payload)
            except CdrError as exc:
                raise GatewayError(f'the request does not decode as {type_name}: {exc}') from None
            return encode(client.call(message))

        return handle

    @property
    def offered(self) -> dict[str, str]:
        """The services offered now (name -> type)."""
        return dict(self._offered)

    def close(self) -> None:
        """Close the service clients."""
        self._clients.close()


def message_from_json(cls: type[Message], data: bytes | str) -> Message:
    """A message from JSON text (objects for nested messages, arrays for sequences; missing
    fields keep their defaults); GatewayError says what is wrong."""
    try:
        fields = json.loads(data)
        return cls.from_dict(fields)
    except (ValueError, TypeError, AttributeError, OverflowError) as exc:
        raise GatewayError(f'cannot make a {cls.__msgtype__} from the JSON given: {exc}') from None

"""Service and action routes of the stand-in (§5, §6).

Deviations from the real bridge, all forced by rclpy:

* the real bridge moves the rmw_cyclonedds request header (client GUID + sequence number) into
  the "rqh" attachment; rclpy hides the request id from service callbacks, so the stand-in sends
  a GUID made from its zid and the service name, and a per-route counter;
* a "rqh" attachment on a query *to* the stand-in cannot become the DDS request id (rclpy
  clients pick their own): it is checked and ignored;
* rclpy carries request ids out of band whatever the RMW, so unlike the real bridge the stand-in
  also serves ROS nodes on rmw_fastrtps.
"""

from __future__ import annotations

import hashlib
import itertools
import logging
from typing import TYPE_CHECKING, Any

import zenoh
from rclpy.serialization import deserialize_message, serialize_message

from tests.interop.bridge_standin import protocol as p
from tests.interop.bridge_standin.topics import (
    Route,
    RoutePublisher,
    RouteSubscriber,
    interface_class,
)

if TYPE_CHECKING:
    from tests.interop.bridge_standin.runtime import StandIn

log = logging.getLogger('standin')


class NoReply(Exception):
    """The Zenoh side gave no usable reply: the ROS client is left waiting, as with the bridge."""


class RouteServiceCli(Route):
    """ROS clients -> Zenoh server (an SS token, or a local ROS client): a Zenoh querier on the
    key; the DDS service server exists only while the querier matches a queryable (>= 1.1.0)."""

    admin_kind = 'service/cli'
    token_kind = p.Kind.SC

    def __init__(
        self,
        bridge: StandIn,
        ros_name: str,
        type_name: str,
        qos: p.TokenQos | None = None,
        *,
        timeout: float = p.SERVICE_TIMEOUT,
        **options: Any,
    ) -> None:
        super().__init__(bridge, ros_name, type_name, None, **options)
        self.srv_class = interface_class(type_name)
        self.timeout = timeout
        self.querier = bridge.session.declare_querier(
            self.key, timeout=timeout, allowed_destination=zenoh.Locality.REMOTE
        )
        self.listener = self.querier.declare_matching_listener(
            lambda _status: bridge.post(self.update)
        )
        digest = hashlib.sha1(f'{bridge.zid}{ros_name}'.encode()).digest()
        self.guid = int.from_bytes(digest[:8], 'little')
        self.sequence = itertools.count(1)
        self.server: Any = None
        self.update()

    @property
    def active(self) -> bool:
        return self.server is not None

    def update(self) -> None:
        if self.closed:
            return
        matching = self.querier.matching_status.matching
        if matching and self.server is None:
            self.server = self.bridge.node.create_service(
                self.srv_class,
                self.ros_name,
                self.on_request,
                callback_group=self.bridge.service_group,
            )
            log.info('route %s: DDS service server created', self.ros_name)
        elif not matching and self.server is not None:
            self.bridge.node.destroy_service(self.server)
            self.server = None
            log.info('route %s: DDS service server deleted', self.ros_name)

    def on_request(self, request: Any, _response: Any) -> Any:
        """A ROS client's request, on an executor thread: query Zenoh, return the first reply."""
        payload = bytes(serialize_message(request))
        attachment = p.request_header_attachment(self.guid, next(self.sequence))
        for reply in self.querier.get(payload=payload, attachment=attachment):
            if reply.ok is None:
                raise NoReply(f'{self.ros_name}: error reply {reply.err.payload.to_string()!r}')
            data = reply.ok.payload.to_bytes()
            if not p.valid_service_payload(data):
                raise NoReply(f'{self.ros_name}: received invalid reply {data[:8].hex()}')
            return deserialize_message(data, self.srv_class.Response)
        raise NoReply(f'{self.ros_name}: no reply within {self.timeout} s')

    def close(self) -> None:
        super().close()
        self.listener.undeclare()
        if self.server is not None:
            self.bridge.node.destroy_service(self.server)
            self.server = None
        self.querier.undeclare()


class RouteServiceSrv(Route):
    """Zenoh clients -> ROS server (an SC token, or a local ROS server): a DDS client from the
    start; the Zenoh queryable exists only while a local ROS server exists."""

    admin_kind = 'service/srv'
    token_kind = p.Kind.SS

    def __init__(
        self,
        bridge: StandIn,
        ros_name: str,
        type_name: str,
        qos: p.TokenQos | None = None,
        **options: Any,
    ) -> None:
        super().__init__(bridge, ros_name, type_name, None, **options)
        self.srv_class = interface_class(type_name)
        self.client = bridge.node.create_client(
            self.srv_class, ros_name, callback_group=bridge.service_group
        )
        self.queryable: Any = None

    @property
    def active(self) -> bool:
        return self.queryable is not None

    def update(self) -> None:
        if self.closed:
            return
        wanted = (bool(self.local_nodes) or not self.announce) and self.client.service_is_ready()
        if wanted and self.queryable is None:
            self.queryable = self.bridge.session.declare_queryable(
                self.key, self.on_query, complete=True, allowed_origin=zenoh.Locality.REMOTE
            )
            log.info('route %s: Zenoh queryable declared', self.ros_name)
        elif not wanted and self.queryable is not None:
            self.queryable.undeclare()
            self.queryable = None
            log.info('route %s: Zenoh queryable undeclared', self.ros_name)

    def on_query(self, query: Any) -> None:
        """A Zenoh query (on a Zenoh thread): call the ROS server, reply once when it answers."""
        payload = query.payload.to_bytes() if query.payload is not None else b''
        if not p.valid_service_payload(payload):
            log.warning('%s: received invalid request %s', self.ros_name, payload[:8].hex())
            query.drop()
            return
        attachment = query.attachment.to_bytes() if query.attachment is not None else None
        if attachment is not None and p.parse_request_header(attachment) is None:
            log.info('%s: attachment %s is no request header', self.ros_name, attachment.hex())
        try:
            request = deserialize_message(payload, self.srv_class.Request)
        except Exception as exc:
            log.warning('%s: cannot deserialize the request: %s', self.ros_name, exc)
            query.drop()
            return
        future = self.client.call_async(request)
        future.add_done_callback(lambda done: self._reply(query, done))

    def _reply(self, query: Any, future: Any) -> None:
        with query:
            response = future.result()
            if response is not None:
                query.reply(self.key, bytes(serialize_message(response)))

    def close(self) -> None:
        super().close()
        if self.queryable is not None:
            self.queryable.undeclare()
            self.queryable = None
        self.bridge.node.destroy_client(self.client)


class _ActionRoute(Route):
    """An action as its three services and two topics (§6); only the action announces a token."""

    def __init__(self, bridge: StandIn, ros_name: str, type_name: str, parts: dict[str, Route]):
        super().__init__(bridge, ros_name, type_name)
        self.parts = parts

    @staticmethod
    def part_args(bridge: StandIn, ros_name: str, type_name: str, part: str) -> dict[str, Any]:
        key = p.ros_to_key(ros_name, bridge.options.namespace)
        return {
            'bridge': bridge,
            'ros_name': f'{ros_name}/_action/{part}',
            'type_name': p.action_part_type(type_name, part),
            'key': p.action_key(key, part),
            'announce': False,
        }

    @property
    def active(self) -> bool:
        return all(part.active for part in self.parts.values())

    def update(self) -> None:
        for part in self.parts.values():
            part.update()

    def admin(self) -> dict[str, Any]:
        info = super().admin()
        info['parts'] = {name: part.admin() for name, part in self.parts.items()}
        return info

    def close(self) -> None:
        super().close()
        for part in self.parts.values():
            part.close()


class RouteActionCli(_ActionRoute):
    """ROS action clients -> Zenoh action server (an AS token, or a local ROS action client)."""

    admin_kind = 'action/cli'
    token_kind = p.Kind.AC

    def __init__(
        self, bridge: StandIn, ros_name: str, type_name: str, qos: p.TokenQos | None = None
    ) -> None:
        def args(part: str) -> dict[str, Any]:
            return self.part_args(bridge, ros_name, type_name, part)

        parts: dict[str, Route] = {}
        try:
            for part in p.ACTION_SERVICES:
                timeout = p.GET_RESULT_TIMEOUT if part == 'get_result' else p.SERVICE_TIMEOUT
                parts[part] = RouteServiceCli(**args(part), timeout=timeout)
            parts['feedback'] = RouteSubscriber(**args('feedback'), qos=p.ACTION_FEEDBACK_QOS)
            parts['status'] = RouteSubscriber(**args('status'), qos=p.ACTION_STATUS_QOS)
        except BaseException:
            for made in parts.values():
                made.close()
            raise
        super().__init__(bridge, ros_name, type_name, parts)


class RouteActionSrv(_ActionRoute):
    """Zenoh action clients -> ROS action server (an AC token, or a local ROS action server)."""

    admin_kind = 'action/srv'
    token_kind = p.Kind.AS

    def __init__(
        self, bridge: StandIn, ros_name: str, type_name: str, qos: p.TokenQos | None = None
    ) -> None:
        def args(part: str) -> dict[str, Any]:
            return self.part_args(bridge, ros_name, type_name, part)

        parts: dict[str, Route] = {}
        try:
            for part in p.ACTION_SERVICES:
                parts[part] = RouteServiceSrv(**args(part))
            parts['feedback'] = RoutePublisher(**args('feedback'), qos=p.ACTION_FEEDBACK_QOS)
            parts['status'] = RoutePublisher(**args('status'), qos=p.ACTION_STATUS_QOS)
        except BaseException:
            for made in parts.values():
                made.close()
            raise
        super().__init__(bridge, ros_name, type_name, parts)

"""The stand-in bridge: routes between an rclpy node and a Zenoh router session.

Threads: route management (the event guard condition, the graph poll timer) and raw DDS samples
run in the node's default (mutually exclusive) callback group, so one at a time; service
callbacks, which wait for Zenoh replies, run in a reentrant group beside them. Zenoh callbacks
(liveliness, matching, data) run on Zenoh threads: data is forwarded from there directly,
everything else is posted as an event for the route-management side.
"""

from __future__ import annotations

import json
import logging
import queue
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import rclpy
import zenoh
from rclpy.action.graph import (
    get_action_client_names_and_types_by_node,
    get_action_server_names_and_types_by_node,
)
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node

from tests.interop.bridge_standin import protocol as p
from tests.interop.bridge_standin.services import (
    NoReply,
    RouteActionCli,
    RouteActionSrv,
    RouteServiceCli,
    RouteServiceSrv,
)
from tests.interop.bridge_standin.topics import (
    EchoFilter,
    Route,
    RoutePublisher,
    RouteSubscriber,
    endpoint_qos,
)

log = logging.getLogger('standin')

GRAPH_PERIOD = 0.1  # seconds between two polls of the rclpy graph

#: the route a token from another Zenoh session asks for (§3.3)
ROUTE_FOR_TOKEN: dict[p.Kind, type[Route]] = {
    p.Kind.MP: RouteSubscriber,
    p.Kind.MS: RoutePublisher,
    p.Kind.SS: RouteServiceCli,
    p.Kind.SC: RouteServiceSrv,
    p.Kind.AS: RouteActionCli,
    p.Kind.AC: RouteActionSrv,
}

Found = dict[str, tuple[str, dict[str, p.TokenQos]]]  # ROS name -> (type, {endpoint: QoS})


@dataclass
class Options:
    listen: list[str]
    namespace: str = '/'
    nodename: str = 'zenoh_bridge_ros2dds'
    version: str = '1.10.0'
    domain: int = 0
    cache_multiplier: int = 10


class StandIn:
    """One bridge: an rclpy node (the DDS side) and a Zenoh router session (the Zenoh side)."""

    def __init__(self, options: Options) -> None:
        p.check_namespace(options.namespace)
        p.check_nodename(options.nodename)
        self.options = options
        self.echo = EchoFilter()
        self.rejected: list[dict[str, str]] = []
        self.accepted = 0
        self._events: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
        self._routes_lock = threading.RLock()
        self.routes: dict[tuple[type[Route], str], Route] = {}
        self.stopping = threading.Event()

        rclpy.init(args=[])
        self.node = Node(
            options.nodename,
            namespace=options.namespace,
            enable_rosout=False,
            start_parameter_services=False,
        )
        self.service_group = ReentrantCallbackGroup()
        self.executor = MultiThreadedExecutor(num_threads=8)
        self.executor.add_node(self.node)
        self._guard = self.node.create_guard_condition(self._drain_events)
        self._timer = self.node.create_timer(GRAPH_PERIOD, self.poll_graph)

        config = {
            'mode': 'router',
            'listen': {'endpoints': options.listen},
            'scouting': {'delay': 0, 'multicast': {'enabled': False}},
            'timestamping': {'enabled': True},
            'adminspace': {'enabled': True},
            'transport': {'shared_memory': {'enabled': False}},
        }
        self.session: Any = zenoh.open(zenoh.Config.from_json5(json.dumps(config)))
        self.zid = str(self.session.zid())
        self.admin_prefix = p.admin_prefix(self.zid)
        self._admin = self.session.declare_queryable(f'{self.admin_prefix}/**', self._on_admin)
        self._plugin_token = self.session.liveliness().declare_token(p.plugin_token(self.zid))
        self._tokens = self.session.liveliness().declare_subscriber(
            p.TOKENS_SELECTOR, self._on_token_sample, history=True
        )

    # --- events ---------------------------------------------------------------------------

    def post(self, event: Callable[[], None]) -> None:
        """Run ``event`` on the route-management side (called from Zenoh threads)."""
        self._events.put(event)
        self._guard.trigger()

    def _drain_events(self) -> None:
        while True:
            try:
                event = self._events.get_nowait()
            except queue.Empty:
                return
            try:
                event()
            except Exception:
                log.exception('event failed')

    def run(self) -> None:
        while not self.stopping.is_set():
            try:
                self.executor.spin_once(timeout_sec=0.1)
            except NoReply as exc:
                # as the real bridge: logged, and the ROS client never gets an answer
                log.warning('%s', exc)
            except Exception:
                log.exception('callback failed')

    def stop(self) -> None:
        self.stopping.set()
        self._guard.trigger()

    def close(self) -> None:
        with self._routes_lock:
            routes = list(self.routes.values())
            self.routes.clear()
        for route in routes:
            route.close()
        self._tokens.undeclare()
        self._plugin_token.undeclare()
        self._admin.undeclare()
        self.session.close()
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown()

    # --- tokens from Zenoh (§3.3) -----------------------------------------------------------

    def _on_token_sample(self, sample: Any) -> None:
        key = str(sample.key_expr)
        put = sample.kind == zenoh.SampleKind.PUT
        self.post(lambda: self.on_token(key, put))

    def reject(self, key: str, reason: str) -> None:
        log.warning('rejected token %s: %s', key, reason)
        with self._routes_lock:
            self.rejected.append({'token': key, 'reason': reason})

    def on_token(self, key: str, put: bool) -> None:
        if key.startswith(f'@/{self.zid}/'):
            return  # our own tokens
        try:
            parsed = p.parse_token(key)
        except p.TokenError as exc:
            if put:
                self.reject(key, str(exc))
            return
        if isinstance(parsed, str):
            log.info('bridge %s %s', parsed, 'appeared' if put else 'left')
            return
        ros_name = p.key_to_ros(parsed.key, self.options.namespace)
        if not p.is_ros_name(ros_name):
            if put:
                # the real bridge tries to create the DDS entity and logs the DDS error
                self.reject(key, f'key {parsed.key!r} maps to {ros_name!r}, not a ROS name')
            return
        route_class = ROUTE_FOR_TOKEN[parsed.kind]
        if put:
            route = self._route(route_class, ros_name, parsed.type_name, parsed.qos, key)
            if route is not None:
                self.accepted += 1
                route.remote_routes.add(parsed.remote_route)
            return
        with self._routes_lock:
            existing = self.routes.get((route_class, ros_name))
        if existing is not None:
            existing.remote_routes.discard(parsed.remote_route)
            self._retire_if_unused(existing)

    def _route(
        self,
        route_class: type[Route],
        ros_name: str,
        type_name: str,
        qos: p.TokenQos | None,
        origin: str,
    ) -> Route | None:
        """The route of ``ros_name``, created with ``type_name``/``qos`` if there is none yet."""
        with self._routes_lock:
            route = self.routes.get((route_class, ros_name))
        if route is not None:
            if route.type_name != type_name:
                # the first announcement fixes the type (§3.3): later ones are ignored
                log.warning('%s: type %s ignored, route has %s', origin, type_name, route.type_name)
                return None
            return route
        try:
            route = route_class(self, ros_name, type_name, qos)
        except Exception as exc:
            self.reject(origin, f'cannot create the route: {exc}')
            return None
        with self._routes_lock:
            self.routes[(route_class, ros_name)] = route
        log.info('route %s %s [%s] created', route.admin_kind, ros_name, type_name)
        return route

    def _retire_if_unused(self, route: Route) -> None:
        if route.needed:
            return
        with self._routes_lock:
            self.routes.pop((type(route), route.ros_name), None)
        route.close()
        log.info('route %s %s retired', route.admin_kind, route.ros_name)

    # --- ROS entities from the rclpy graph ----------------------------------------------------

    def _is_own(self, name: str, namespace: str) -> bool:
        return name == self.options.nodename and namespace == self.options.namespace

    def _discover_topics(self) -> tuple[Found, Found]:
        publishers: Found = {}
        subscribers: Found = {}
        for name, types in self.node.get_topic_names_and_types():
            if '/_action/' in name or not types:
                continue  # action topics belong to action routes
            for infos, found in (
                (self.node.get_publishers_info_by_topic(name), publishers),
                (self.node.get_subscriptions_info_by_topic(name), subscribers),
            ):
                endpoints = {
                    bytes(info.endpoint_gid).hex(): endpoint_qos(
                        info.qos_profile, info.topic_type_hash
                    )
                    for info in infos
                    if not self._is_own(info.node_name, info.node_namespace)
                }
                if endpoints:
                    found[name] = (types[0], endpoints)
        return publishers, subscribers

    def _discover_by_node(self) -> dict[type[Route], Found]:
        """Service servers/clients and action servers/clients, per remote node."""
        found: dict[type[Route], Found] = {
            RouteServiceSrv: {},
            RouteServiceCli: {},
            RouteActionSrv: {},
            RouteActionCli: {},
        }
        node = self.node
        for name, namespace in node.get_node_names_and_namespaces():
            if self._is_own(name, namespace):
                continue
            owner = f'{namespace.rstrip("/")}/{name}'
            listings: list[tuple[type[Route], list[tuple[str, list[str]]]]] = [
                (RouteServiceSrv, node.get_service_names_and_types_by_node(name, namespace)),
                (RouteServiceCli, node.get_client_names_and_types_by_node(name, namespace)),
                (RouteActionSrv, get_action_server_names_and_types_by_node(node, name, namespace)),
                (RouteActionCli, get_action_client_names_and_types_by_node(node, name, namespace)),
            ]
            for route_class, entries in listings:
                for ros_name, types in entries:
                    if not types or '/_action/' in ros_name:
                        continue
                    _, endpoints = found[route_class].setdefault(ros_name, (types[0], {}))
                    endpoints[owner] = p.TokenQos()
        return found

    def poll_graph(self) -> None:
        """Routes for the ROS entities that exist now (a few times a second)."""
        publishers, subscribers = self._discover_topics()
        found = {RoutePublisher: publishers, RouteSubscriber: subscribers}
        found.update(self._discover_by_node())
        for route_class, entities in found.items():
            for name, (type_name, endpoints) in entities.items():
                first_qos = next(iter(endpoints.values()))
                route = self._route(route_class, name, type_name, first_qos, f'ROS {name}')
                if route is not None and route.local_nodes.keys() != endpoints.keys():
                    route.set_local(endpoints)
            with self._routes_lock:
                gone = [
                    route
                    for (kind, name), route in self.routes.items()
                    if kind is route_class and name not in entities
                ]
            for route in gone:
                if route.local_nodes:
                    route.set_local({})
                self._retire_if_unused(route)
        with self._routes_lock:
            routes = list(self.routes.values())
        for route in routes:
            route.update()

    # --- admin space (§8) ---------------------------------------------------------------------

    def _admin_items(self) -> dict[str, str]:
        items = {
            f'{self.admin_prefix}/version': p.version_json(self.options.version),
            f'{self.admin_prefix}/config': p.config_json(
                self.options.namespace, self.options.nodename, self.options.domain
            ),
        }
        with self._routes_lock:
            for route in self.routes.values():
                items[f'{self.admin_prefix}/route/{route.admin_kind}/{route.key}'] = json.dumps(
                    route.admin()
                )
            # not in the real bridge: what the tests read to see rejected tokens
            items[f'{self.admin_prefix}/standin/rejected'] = json.dumps(self.rejected)
            items[f'{self.admin_prefix}/standin/accepted'] = json.dumps(self.accepted)
        return items

    def _on_admin(self, query: Any) -> None:
        with query:
            selector = query.key_expr
            for key, value in self._admin_items().items():
                if selector.intersects(zenoh.KeyExpr(key)):
                    query.reply(key, value, encoding=zenoh.Encoding.APPLICATION_JSON)

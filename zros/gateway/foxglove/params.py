"""The parameters of every node, for Foxglove's Parameters panel, as foxglove_bridge names them.

A parameter is ``<node>.<name>`` (``/robot/driver.max_speed``); asking for no names lists every
parameter of every node that serves them (found by its ``get_parameters`` and
``list_parameters`` services, which also finds ROS nodes behind a bridge). Reads and writes go
through zros's parameter client; clients that subscribe get changes as ``/parameter_events``
reports them.
"""

from __future__ import annotations

import concurrent.futures
import logging
import threading
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

from zros.cdr import CdrError
from zros.cdr.message import decode
from zros.errors import ZrosError
from zros.gateway.common.entities import PARAMETER_NODES, ClientCache
from zros.gateway.common.filters import NameFilter
from zros.params.descriptor import Parameter
from zros.params.errors import ParameterError
from zros.params.values import ParameterType, describe_value, from_message, is_param_value
from zros.pubsub.taps import RawTap
from zros.qos import PARAMETER_EVENTS
from zros.version import counted

if TYPE_CHECKING:
    import foxglove
    import zenoh
    from foxglove import AnyInnerParameterValue

    from zros.cdr import Message
    from zros.node import Node
    from zros.params import ParamValue
    from zros.params.client import ParameterClient

_log = logging.getLogger('zros.gateway')

#: seconds a node has to answer a parameter request
TIMEOUT = 3.0
#: nodes asked at once
_WORKERS = 8
#: parameters followed at once, all clients together (the SDK tells only their union)
MAX_FOLLOWED = 10_000


def split_name(full: str) -> tuple[str, str]:
    """``/node.param.sub`` -> (``/node``, ``param.sub``) (the node is before the first dot)."""
    node, _, name = full.partition('.')
    return node, name


def to_foxglove(
    full: str, value: ParamValue, kind: ParameterType | None = None
) -> foxglove.Parameter:
    """A foxglove.Parameter of a zros value (doubles keep their type hint, as
    foxglove_bridge sends them; an empty array takes its type from ``kind``)."""
    import foxglove  # noqa: PLC0415 (optional: the foxglove extra)

    if value is None:
        return foxglove.Parameter(full)
    if kind is ParameterType.DOUBLE or isinstance(value, float):
        return foxglove.Parameter(full, value=_number(value), type=foxglove.ParameterType.Float64)
    if kind is ParameterType.DOUBLE_ARRAY and isinstance(value, list):
        floats: list[AnyInnerParameterValue] = [_number(item) for item in value]
        return foxglove.Parameter(full, value=floats, type=foxglove.ParameterType.Float64Array)
    if isinstance(value, list):  # foxglove infers the type
        items: list[AnyInnerParameterValue] = list(value)
        return foxglove.Parameter(full, value=items)
    return foxglove.Parameter(full, value=value)


def from_foxglove(parameter: foxglove.Parameter) -> tuple[ParamValue, ParameterType | None]:
    """The zros value and type of a foxglove.Parameter (None deletes)."""
    import foxglove  # noqa: PLC0415 (optional: the foxglove extra)

    value = parameter.get_value()  # a client's: converted as its type hint says
    hint = parameter.type
    if value is None:
        return None, ParameterType.NOT_SET
    if hint == foxglove.ParameterType.Float64:
        return _number(value), ParameterType.DOUBLE
    if hint == foxglove.ParameterType.Float64Array:
        if not isinstance(value, list):
            raise TypeError(f'{value!r} is not an array')
        return [_number(item) for item in value], ParameterType.DOUBLE_ARRAY
    if hint == foxglove.ParameterType.ByteArray:
        if isinstance(value, list):
            return bytes(int(_number(item)) for item in value), ParameterType.BYTE_ARRAY
        if not isinstance(value, bytes):
            raise TypeError(f'{value!r} is not bytes')
        return value, ParameterType.BYTE_ARRAY
    if not is_param_value(value):
        raise ParameterError(f'{describe_value(value)} is no parameter value')
    return value, None


def _number(value: object) -> float:
    """A number of a client's parameter (TypeError when it is none)."""
    if not isinstance(value, (int, float, str)):
        raise TypeError(f'{value!r} is not a number')
    return float(value)


class Parameters:
    """Gets, sets and follows the parameters of the graph's nodes. ``nodes()`` lists the nodes
    serving parameters; ``publish(parameters)`` sends updates to subscribed clients;
    ``status(text)`` tells clients what went wrong."""

    def __init__(
        self,
        node: Node,
        allowed: NameFilter,
        nodes: Callable[[], list[str]],
        publish: Callable[[list[foxglove.Parameter]], object],
        status: Callable[[str], object],
    ) -> None:
        self._node = node
        self._allowed = allowed
        self._nodes = nodes
        self._publish = publish
        self._status = status
        self._lock = threading.Lock()
        self._clients: ClientCache[ParameterClient] = ClientCache(PARAMETER_NODES)
        self._subscribed: set[str] = set()
        self._events: RawTap | None = None
        self._pool = concurrent.futures.ThreadPoolExecutor(_WORKERS, 'zros foxglove parameters')

    def _client(self, node_name: str) -> ParameterClient:
        return self._clients.get(node_name, lambda: self._node.parameter_client(node_name, TIMEOUT))

    def _of_node(self, node_name: str, names: list[str] | None) -> list[foxglove.Parameter]:
        client = self._client(node_name)
        if names is None:
            names = client.list_parameters()
        values = client.get_parameters(names)
        empty = [name for name, value in values.items() if value == []]
        kinds = client.get_parameter_types(empty) if empty else {}
        found = []
        for name, value in values.items():
            full = f'{node_name}.{name}'
            if value is not None and self._allowed(full):
                found.append(to_foxglove(full, value, kinds.get(name)))
        return found

    def _each_node(self, wanted: dict[str, list[str] | None]) -> list[foxglove.Parameter]:
        futures = {n: self._pool.submit(self._of_node, n, names) for n, names in wanted.items()}
        found = []
        for node_name, future in futures.items():
            try:
                found += future.result()
            except (ZrosError, OSError) as exc:
                _log.warning('no parameters from %s: %s', node_name, exc)
        return found

    def get(self, names: Iterable[str]) -> list[foxglove.Parameter]:
        """The parameters named (``/node.param``), or every parameter when none is named."""
        names = list(names)
        wanted: dict[str, list[str] | None] = {}
        for full in names:
            node_name, name = split_name(full)
            if name and self._allowed(full):
                listed = wanted.setdefault(node_name, [])
                assert listed is not None
                listed.append(name)
        if not wanted and not names:
            wanted = dict.fromkeys(self._nodes())
        return self._each_node(wanted)

    def set(self, parameters: Iterable[foxglove.Parameter]) -> list[foxglove.Parameter]:
        """Set parameters, node by node; returns their values afterwards (a refused value
        stays as it was, and the clients are told why)."""
        by_node: dict[str, list[Parameter]] = {}
        for parameter in parameters:
            node_name, name = split_name(parameter.name)
            if not name or not self._allowed(parameter.name):
                self._status(f'the parameter {parameter.name} may not be set through this server')
                continue
            try:
                value, kind = from_foxglove(parameter)
            except ParameterError as exc:
                self._status(f'cannot set {parameter.name}: {exc}')
                continue
            by_node.setdefault(node_name, []).append(Parameter(name, value, kind))
        futures = {
            n: self._pool.submit(self._client(n).set_parameters, items)
            for n, items in by_node.items()
        }
        for node_name, future in futures.items():
            try:
                results = future.result()
            except (ZrosError, OSError) as exc:
                self._status(f'cannot set parameters of {node_name}: {exc}')
                continue
            for item, result in zip(by_node[node_name], results, strict=False):
                if not result:
                    self._status(f'{node_name} refused {item.name}: {result.reason}')
        return self._each_node({n: [item.name for item in items] for n, items in by_node.items()})

    # --- updates ---------------------------------------------------------------------------------

    def subscribe(self, names: Iterable[str]) -> None:
        """Send clients the changes of these parameters (from ``/parameter_events``): those the
        server offers, up to :data:`MAX_FOLLOWED` at once; clients are told of the others."""
        names = list(dict.fromkeys(names))
        offered = [full for full in names if split_name(full)[1] and self._allowed(full)]
        with self._lock:
            new = [full for full in offered if full not in self._subscribed]
            room = max(0, MAX_FOLLOWED - len(self._subscribed))
            self._subscribed.update(new[:room])
            if self._events is None and self._subscribed:
                cls = self._node.registry.get_class('rcl_interfaces/msg/ParameterEvent')
                self._events = RawTap(
                    self._node,
                    '/parameter_events',
                    cls.__msgtype__,
                    qos=PARAMETER_EVENTS,
                    key=None,
                    callback=self._event_callback(cls),
                )
        hidden = [full for full in names if full not in offered]
        if hidden:  # one status however many: a client may send thousands
            self._status(
                f'{counted(len(hidden), "parameter")} may not be followed through this server '
                f'({hidden[0]}{", ..." if len(hidden) > 1 else ""})'
            )
        if len(new) > room:
            self._status(
                f'{counted(len(new) - room, "parameter")} not followed: this server follows at '
                f'most {MAX_FOLLOWED} at once'
            )

    def unsubscribe(self, names: Iterable[str]) -> None:
        """Stop sending the changes of these parameters."""
        with self._lock:
            self._subscribed.difference_update(names)
            events = self._events if not self._subscribed else None
            if events is not None:
                self._events = None
        if events is not None:
            events.close()

    def _event_callback(self, cls: type[Message]) -> Callable[[zenoh.Sample], None]:
        def on_event(sample: zenoh.Sample) -> None:
            try:
                event = decode(cls, sample.payload.to_bytes())
            except CdrError as exc:
                _log.debug('a /parameter_events message does not decode: %s', exc)
                return
            updates = []
            for item in (*event.new_parameters, *event.changed_parameters):
                full = f'{event.node}.{item.name}'
                if full in self._subscribed:
                    value, kind = from_message(item.value)
                    updates.append(to_foxglove(full, value, kind))
            if updates:
                self._publish(updates)

        return on_event

    def close(self) -> None:
        """Stop following events and close the parameter clients."""
        self.unsubscribe(list(self._subscribed))
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._clients.close()

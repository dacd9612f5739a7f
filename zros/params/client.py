"""The parameters of another node (zros, or ROS 2 behind a bridge), through its services."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping

from zros.cdr import Message
from zros.deprecation import deprecated
from zros.keyexpr.names import validate_full_name
from zros.params.descriptor import Descriptor, Parameter, SetResult
from zros.params.errors import NodeNotFoundError, ParameterError, ParameterTimeoutError
from zros.params.server import SERVICE_TYPES
from zros.params.values import ParameterType, ParamValue, from_message, infer_type, to_message
from zros.pubsub import Subscriber
from zros.qos import PARAMETER_EVENTS
from zros.runtime.clock import Time
from zros.runtime.defaults import NodeLike, default_node
from zros.services import Client, ServiceTimeoutError, ServiceUnavailableError


class ParameterClient:
    """Reads and sets the parameters of the node ``node_name`` (fully qualified, e.g.
    ``/robot/driver``), from ``node`` (None: the default node of ``zros.init``;
    ``node.parameter_client`` is the node's way). Every call waits at most ``timeout`` seconds."""

    def __init__(
        self,
        node_name: str | NodeLike,
        *args: str | float,
        node: NodeLike | None = None,
        timeout: float = 5.0,
    ) -> None:
        if not isinstance(node_name, str):  # the old order: (node, node_name, timeout)
            if node is not None or not args or not isinstance(args[0], str) or len(args) > 2:
                raise TypeError('ParameterClient takes (node_name, node=None, timeout=5.0)')
            deprecated('ParameterClient(node, node_name)', 'ParameterClient(node_name, node=node)')
            node, node_name = node_name, args[0]
            if len(args) == 2:
                timeout = float(args[1])
        elif args:
            raise TypeError('ParameterClient takes (node_name, node=None, timeout=5.0)')
        if node is None:
            node = default_node()
        if not node_name.startswith('/'):
            node_name = '/' + node_name
        validate_full_name(node_name, 'node name')
        self.node = node
        self.target = node_name
        self.timeout = timeout
        self._clients: dict[str, Client] = {
            name: Client(f'{node_name}/{name}', srv_type, node=node, announce=False)
            for name, srv_type in SERVICE_TYPES.items()
        }
        registry = node.context.registry
        self._Value = registry.get_class('rcl_interfaces/msg/ParameterValue')
        self._Parameter = registry.get_class('rcl_interfaces/msg/Parameter')

    def _call(self, service: str, timeout: float | None, **fields: object) -> Message:
        client = self._clients[service]
        wait = self.timeout if timeout is None else timeout
        try:
            response: Message = client.call(client.Request(**fields), wait)
            return response
        except ServiceUnavailableError:
            raise NodeNotFoundError(
                f'no node {self.target} serves parameters (nothing answers {client.name})'
            ) from None
        except ServiceTimeoutError:
            raise ParameterTimeoutError(
                f'node {self.target} did not answer {service} within {wait:g} s'
            ) from None

    def wait_for_node(self, timeout: float | None = 5.0) -> bool:
        """Wait until the node's parameter services are reachable."""
        return self._clients['get_parameters'].wait_for_service(timeout)

    def list_parameters(
        self, prefixes: Iterable[str] = (), depth: int = 0, timeout: float | None = None
    ) -> list[str]:
        """Parameter names (all, or under ``prefixes``, ``depth`` levels deep; 0 is all)."""
        response = self._call('list_parameters', timeout, prefixes=list(prefixes), depth=depth)
        return list(response.result.names)

    def get_parameters(
        self, names: Iterable[str], timeout: float | None = None
    ) -> dict[str, ParamValue]:
        """Values by name; names the node does not have map to None."""
        names = list(names)
        response = self._call('get_parameters', timeout, names=names)
        values = [from_message(value)[0] for value in response.values]
        if len(values) == len(names):
            return dict(zip(names, values, strict=True))
        # rclcpp answers nothing at all when one name is undeclared: ask one by one
        if len(names) == 1:
            return {names[0]: None}
        return {name: self.get(name, timeout) for name in names}

    def get(self, name: str, timeout: float | None = None) -> ParamValue:
        """One parameter's value (None when the node does not have it)."""
        return self.get_parameters([name], timeout)[name]

    def get_parameter_types(
        self, names: Iterable[str], timeout: float | None = None
    ) -> dict[str, ParameterType]:
        """The type of each of ``names`` (``NOT_SET`` when absent)."""
        names = list(names)
        response = self._call('get_parameter_types', timeout, names=names)
        kinds = [ParameterType(kind) for kind in response.types]
        if len(kinds) != len(names):
            return dict.fromkeys(names, ParameterType.NOT_SET)
        return dict(zip(names, kinds, strict=True))

    def describe_parameters(
        self, names: Iterable[str], timeout: float | None = None
    ) -> dict[str, Descriptor]:
        """The descriptors (type, ranges, read-only...) of ``names``."""
        names = list(names)
        response = self._call('describe_parameters', timeout, names=names)
        found = [Descriptor.from_message(message) for message in response.descriptors]
        if len(found) != len(names):
            return {name: Descriptor(name=name) for name in names}
        return {
            name: dataclasses.replace(d, name=name) for name, d in zip(names, found, strict=True)
        }

    def _messages(self, values: Mapping[str, ParamValue] | Iterable[Parameter]) -> list[Message]:
        items = (
            [Parameter(name, value) for name, value in values.items()]
            if isinstance(values, Mapping)
            else list(values)
        )
        messages = []
        for item in items:
            kind = item.type if item.type is not None else infer_type(item.value)
            value = to_message(item.value, kind, self._Value)
            messages.append(self._Parameter(name=item.name, value=value))
        return messages

    def set_parameters(
        self, values: Mapping[str, ParamValue] | Iterable[Parameter], timeout: float | None = None
    ) -> list[SetResult]:
        """Set parameters one by one (each may fail on its own); None deletes a parameter."""
        response = self._call('set_parameters', timeout, parameters=self._messages(values))
        return [SetResult(r.successful, r.reason) for r in response.results]

    def set_parameters_atomically(
        self, values: Mapping[str, ParamValue] | Iterable[Parameter], timeout: float | None = None
    ) -> SetResult:
        """Set parameters all or none."""
        messages = self._messages(values)
        response = self._call('set_parameters_atomically', timeout, parameters=messages)
        return SetResult(response.result.successful, response.result.reason)

    def set(self, name: str, value: ParamValue, timeout: float | None = None) -> None:
        """Set one parameter; raises ParameterError with the node's reason if it refuses."""
        (result,) = self.set_parameters({name: value}, timeout)
        if not result:
            raise ParameterError(f'{self.target} refused to set {name}: {result.reason}')

    def close(self) -> None:
        """Close the service clients to the node."""
        for client in self._clients.values():
            client.close()

    def __repr__(self) -> str:
        return f'<zros ParameterClient of {self.target}>'


@dataclasses.dataclass(frozen=True)
class ParameterEvent:
    """One ``/parameter_events`` message, with plain values."""

    node: str
    stamp: Time
    new: dict[str, ParamValue]
    changed: dict[str, ParamValue]
    deleted: list[str]

    @classmethod
    def from_message(cls, message: Message) -> ParameterEvent:
        """The event of an ``rcl_interfaces/msg/ParameterEvent`` message."""

        def values(items: Iterable[Message]) -> dict[str, ParamValue]:
            return {item.name: from_message(item.value)[0] for item in items}

        return cls(
            node=message.node,
            stamp=Time.from_msg(message.stamp),
            new=values(message.new_parameters),
            changed=values(message.changed_parameters),
            deleted=[item.name for item in message.deleted_parameters],
        )


def subscribe_parameter_events(
    node: NodeLike, callback: Callable[[ParameterEvent], object], node_name: str | None = None
) -> Subscriber[Message]:
    """Call ``callback(event)`` (while ``node`` spins) for each parameter change on the network,
    or only those of ``node_name``."""

    def on_message(message: Message) -> None:
        if node_name is None or message.node == node_name:
            callback(ParameterEvent.from_message(message))

    return Subscriber(
        '/parameter_events', 'rcl_interfaces/msg/ParameterEvent', on_message, PARAMETER_EVENTS,
        node=node,
    )  # fmt: skip

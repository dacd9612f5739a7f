"""The listener of the live gateway's SDK server: what clients ask, handed to the gateway."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING, ParamSpec, Protocol, TypeVar

if TYPE_CHECKING:
    from foxglove.websocket import ChannelView, Client, ClientChannel, Parameter

    from zros.gateway.foxglove.calls import ClientChannels
    from zros.gateway.foxglove.params import Parameters

_log = logging.getLogger('zros.gateway')
_T = TypeVar('_T')
_P = ParamSpec('_P')


class Gateway(Protocol):
    """What the listener hands requests to
    (:class:`~zros.gateway.foxglove.server.FoxgloveGateway`)."""

    clients: ClientChannels
    parameters: Parameters

    def watch(self, client: int, channel_id: int) -> None: ...

    def unwatch(self, client: int, channel_id: int) -> None: ...

    def advertise(self, client: int, channel: ClientChannel) -> None: ...

    def set_parameters(self, parameters: list[Parameter]) -> list[Parameter]: ...

    def status(self, text: str, level: str = 'warning') -> None: ...


class Listener:
    """The SDK's server listener: requests of clients, handed to the gateway's parts. A
    failure is logged and told to the clients; it never reaches the SDK."""

    def __init__(self, gateway: Gateway) -> None:
        self._gateway = gateway

    def _guard(
        self, what: str, call: Callable[_P, _T], *args: _P.args, **kwargs: _P.kwargs
    ) -> _T | None:
        try:
            return call(*args, **kwargs)
        except Exception as exc:  # a client's request: logged and told, never raised into the SDK
            _log.debug('%s failed', what, exc_info=True)
            self._gateway.status(f'{what} failed: {exc}', 'error')
            return None

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self._guard(f'subscribing to {channel.topic}', self._gateway.watch, client.id, channel.id)

    def on_unsubscribe(self, client: Client, channel: ChannelView) -> None:
        self._guard(f'unsubscribing {channel.topic}', self._gateway.unwatch, client.id, channel.id)

    def on_client_advertise(self, client: Client, channel: ClientChannel) -> None:
        self._guard(f'advertising {channel.topic}', self._gateway.advertise, client.id, channel)

    def on_client_unadvertise(self, client: Client, client_channel_id: int) -> None:
        self._gateway.clients.unadvertise(client.id, client_channel_id)

    def on_message_data(self, client: Client, client_channel_id: int, data: bytes) -> None:
        self._guard('publishing', self._gateway.clients.message, client.id, client_channel_id, data)

    def on_get_parameters(
        self, client: Client, param_names: list[str], request_id: str | None = None
    ) -> list[Parameter]:
        return self._guard('getting parameters', self._gateway.parameters.get, param_names) or []

    def on_set_parameters(
        self, client: Client, parameters: list[Parameter], request_id: str | None = None
    ) -> list[Parameter]:
        return self._guard('setting parameters', self._gateway.set_parameters, parameters) or []

    def on_parameters_subscribe(self, param_names: list[str]) -> None:
        self._guard('following parameters', self._gateway.parameters.subscribe, param_names)

    def on_parameters_unsubscribe(self, param_names: list[str]) -> None:
        self._gateway.parameters.unsubscribe(param_names)

    def on_connection_graph_subscribe(self) -> None:
        """The SDK sends the last graph published to a new subscriber by itself."""

    def on_connection_graph_unsubscribe(self) -> None:
        """Nothing to release: the graph is published on every change anyway."""

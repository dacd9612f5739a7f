"""One rosbridge client: its messages in, its bounded outbox out, its status messages.

Messages are read on the connection's thread and handed to the gateway's parts by ``op``;
whatever a part refuses (a missing field, a type that does not fit, a name not allowed) comes
back as a ``status`` message of level ``error`` naming the op (and its ``id``), as rosbridge
logs it. A client chooses which statuses it gets with ``set_level`` (``error`` by default, as
the rosbridge v2 protocol says).

What the client is sent goes through a :class:`~zros.gateway.core.SendQueue` drained by a
writer thread of its own: a client that reads slowly loses its oldest messages (counted, and
told with an ``error`` status at the start of each burst of losses) and never holds up the
graph or the other clients.
"""

from __future__ import annotations

import collections
import json
import logging
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

from zros.errors import ZrosError
from zros.gateway.core import GatewayError, SendQueue
from zros.gateway.rosbridge_frames import Frames, encode

if TYPE_CHECKING:
    from websockets.sync.server import ServerConnection

    from zros.cdr import JsonValue
    from zros.gateway.json_types import JsonObject
    from zros.gateway.rosbridge_calls import Calls
    from zros.gateway.rosbridge_topics import Topics

_log = logging.getLogger('zros.gateway')

#: status levels, least severe first; a client gets those at or above its level
LEVELS = ('info', 'warning', 'error', 'none')
#: partially received fragmented messages a client may have at once
MAX_PARTIAL = 16

#: the fields each op needs, and their JSON types (rosbridge's ``basic_type_check``)
_REQUIRED: dict[str, tuple[tuple[str, type | tuple[type, ...]], ...]] = {
    'advertise': (('topic', str), ('type', str)),
    'unadvertise': (('topic', str),),
    'publish': (('topic', str),),
    'subscribe': (('topic', str),),
    'unsubscribe': (('topic', str),),
    'call_service': (('service', str),),
    'advertise_service': (('service', str), ('type', str)),
    'unadvertise_service': (('service', str),),
    'service_response': (('service', str), ('result', bool)),
    'send_action_goal': (('action', str), ('action_type', str)),
    'cancel_action_goal': (('action', str),),
    'advertise_action': (('action', str), ('type', str)),
    'unadvertise_action': (('action', str),),
    'action_feedback': (('action', str), ('id', str)),
    'action_result': (('action', str), ('id', str), ('result', bool)),
    'set_level': (('level', str),),
    'fragment': (('id', (str, int)), ('data', str), ('num', int), ('total', int)),
}
_OPTIONAL: dict[str, type | tuple[type, ...]] = {
    'type': str,
    'throttle_rate': int,
    'queue_length': int,
    'fragment_size': (int, type(None)),
    'compression': str,
}


def check_fields(op: str, message: JsonObject) -> None:
    """Refuse a message missing a field its op needs, or with a field of the wrong type."""
    for name, kind in _REQUIRED.get(op, ()):
        if name not in message:
            raise GatewayError(f'Expected a {name} field but none was found.')
        if not isinstance(message[name], kind) or (kind is int and isinstance(message[name], bool)):
            raise GatewayError(
                f'Expected field {name} to be one of {kind}. Invalid value: {message[name]!r}'
            )
    for name, kind in _OPTIONAL.items():
        value = message.get(name)
        if value is not None and (not isinstance(value, kind) or isinstance(value, bool)):
            raise GatewayError(
                f'Expected field {name} to be one of {kind}. Invalid value: {value!r}'
            )


class ClientSession:
    """A connected client (``connection`` is a websockets ``ServerConnection``)."""

    def __init__(
        self,
        client_id: int,
        connection: ServerConnection,
        topics: Topics,
        calls: Calls,
        *,
        max_message_size: int,
        queue_items: int,
        queue_bytes: int,
    ) -> None:
        self.id = client_id
        self.connection = connection
        self._topics = topics
        self._calls = calls
        self.max_message_size = max_message_size
        self.level = LEVELS.index('error')
        self.outbox: SendQueue[Frames] = SendQueue(queue_items, queue_bytes, self._dropped)
        self._notice: Frames | None = None  #: the status of a burst of drops, to send first
        self._partial: collections.OrderedDict[JsonValue, dict[int, str]] = (
            collections.OrderedDict()
        )
        self._ops: dict[str, Callable[[JsonObject], object]] = {
            'advertise': lambda m: topics.advertise(self, m),
            'unadvertise': lambda m: topics.unadvertise(self, m),
            'publish': lambda m: topics.publish(self, m),
            'subscribe': lambda m: topics.subscribe(self, m),
            'unsubscribe': lambda m: topics.unsubscribe(self, m),
            'call_service': lambda m: calls.call_service(self, m),
            'advertise_service': lambda m: calls.advertise_service(self, m),
            'unadvertise_service': lambda m: calls.unadvertise_service(self, m),
            'service_response': lambda m: calls.service_response(self, m),
            'send_action_goal': lambda m: calls.send_action_goal(self, m),
            'cancel_action_goal': lambda m: calls.cancel_action_goal(self, m),
            'advertise_action': lambda m: calls.served.advertise_action(self, m),
            'unadvertise_action': lambda m: calls.served.unadvertise_action(self, m),
            'action_feedback': lambda m: calls.served.action_feedback(self, m),
            'action_result': lambda m: calls.served.action_result(self, m),
            'set_level': self._set_level,
            'fragment': self._fragment,
        }
        self._writer = threading.Thread(
            target=self._write, name=f'zros rosbridge client {client_id}', daemon=True
        )

    def run(self) -> None:
        """Serve the client until it leaves (on the connection's thread)."""
        from websockets.exceptions import ConnectionClosed

        self._writer.start()
        try:
            for raw in self.connection:
                self.incoming(raw)
        except ConnectionClosed as exc:
            _log.info('client %d: %s', self.id, exc)
        finally:
            self.close()

    # --- in ----------------------------------------------------------------------------------

    def incoming(self, raw: str | bytes) -> None:
        """Handle one message from the client."""
        try:
            message = json.loads(raw)
        except (ValueError, UnicodeDecodeError) as exc:
            self.status('error', f'a message that is not JSON was dropped: {exc}')
            return
        if not isinstance(message, dict):
            self.status(
                'error', f'a message that is not a JSON object was dropped: {str(raw)[:80]}'
            )
            return
        op, op_id = message.get('op'), message.get('id')
        handler = self._ops.get(op) if isinstance(op, str) else None
        if handler is None or not isinstance(op, str):
            if op is None:
                text = 'Received a message without an op.  All messages require'
                text += f" 'op' field with value one of: {list(self._ops)}."
            else:
                text = f'Unknown operation: {op}.  Allowed operations: {list(self._ops)}'
            self.status('error', text, op_id)
            return
        try:
            check_fields(op, message)
            handler(message)
        except (GatewayError, ZrosError, ValueError, TypeError, KeyError) as exc:
            _log.debug('client %d: %s failed', self.id, op, exc_info=True)
            self.status('error', f'{op}: {exc}', op_id)

    def _set_level(self, message: JsonObject) -> None:
        level = message['level']
        if level in LEVELS:
            self.level = LEVELS.index(level)

    def _fragment(self, message: JsonObject) -> None:
        """Put fragments back together (bounded by the message size and ``MAX_PARTIAL``)."""
        key, total, num = message['id'], message['total'], message['num']
        if not 0 <= num < total or total > self.max_message_size:  # a character each at least
            raise GatewayError(f'fragment {num} of {total} is out of range')
        parts = self._partial.setdefault(key, {})
        self._partial.move_to_end(key)
        parts[num] = message['data']
        if sum(len(p) for p in parts.values()) > self.max_message_size:
            del self._partial[key]
            raise GatewayError(f'the fragments of {key!r} exceed {self.max_message_size} bytes')
        while len(self._partial) > MAX_PARTIAL:
            self._partial.popitem(last=False)
        if len(parts) == total:
            del self._partial[key]
            self.incoming(''.join(parts[n] for n in range(total)))

    # --- out ---------------------------------------------------------------------------------

    def send(self, message: JsonObject, compression: str = 'none', fragment_size: int = 0) -> None:
        """Queue a protocol message (values in rosbridge's shapes) for the client."""
        size = min(fragment_size or self.max_message_size, self.max_message_size)
        try:
            frames = encode(message, compression, size)
        except (ValueError, TypeError) as exc:
            _log.error(
                'client %d: a %s message does not encode: %s', self.id, message.get('op'), exc
            )
            return
        self.send_frames(frames)

    def send_frames(self, frames: Frames) -> None:
        """Queue encoded frames (dropped with the oldest when the client falls behind)."""
        self.outbox.put(frames, sum(len(frame) for frame in frames))

    def status(self, level: str, text: str, op_id: JsonValue = None) -> None:
        """A status message, if the client wants this level (and a log line here)."""
        prefix = f'[client {self.id}]' + (f' [id: {op_id}]' if op_id is not None else '')
        _log.log(logging.WARNING if level == 'error' else logging.INFO, '%s %s', prefix, text)
        if LEVELS.index(level) >= self.level:
            status: JsonObject = {'op': 'status', 'level': level, 'msg': text}
            if op_id is not None:
                status['id'] = op_id
            self.send(status)

    def _dropped(self, dropped: int) -> None:
        text = (
            f'this client reads too slowly: its oldest messages are being dropped '
            f'({dropped} so far; room for {self.outbox.max_items} messages, '
            f'{self.outbox.max_bytes} bytes)'
        )
        _log.warning('[client %d] %s', self.id, text)
        if LEVELS.index('error') >= self.level:  # sent ahead of the queue: never dropped
            self._notice = encode({'op': 'status', 'level': 'error', 'msg': text})

    @property
    def dropped(self) -> int:
        """Messages dropped because the client read too slowly."""
        return self.outbox.dropped

    def _write(self) -> None:
        from websockets.exceptions import ConnectionClosed

        while (frames := self.outbox.get()) is not None:
            notice, self._notice = self._notice, None
            try:
                for frame in (*(notice or ()), *frames):
                    self.connection.send(frame)
            except ConnectionClosed:
                return

    # --- lifetime ----------------------------------------------------------------------------

    def close(self) -> None:
        """The client left: release what it held and stop its writer."""
        self.outbox.close()
        try:
            self._topics.drop(self.id)
            self._calls.drop(self)
        finally:
            if self._writer.is_alive() and threading.current_thread() is not self._writer:
                self._writer.join(5.0)

    def __repr__(self) -> str:
        return f'<zros rosbridge client {self.id}>'

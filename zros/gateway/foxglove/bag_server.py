"""``zros foxglove --bag PATH``: a recording served to Foxglove with play, pause, speed and seek.

Any bag zros reads (rosbag2 MCAP or SQLite, split or not, ROS 1) becomes one channel per topic
with the recording's own definitions as schemas (zros's when a recording carries none, or one
its first message shows wrong). The Foxglove SDK's playback control drives a
:class:`~zros.bag.play.play_clock.PlayClock`: messages go out with their recorded spacing, the
server's time follows the bag, and a seek
restarts reading at the new time after sending again the latched messages (``/tf_static``,
``/robot_description``) recorded before it. No Zenoh session is needed.
"""

from __future__ import annotations

import collections
import logging
import os
import threading
import time
from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING

from zros.bag.play.play_clock import PlayClock
from zros.bag.read.rosbag2_yaml import parse_qos_profiles
from zros.bag.read.source import RawMessage, open_source
from zros.bag.read.types import BagTypes
from zros.cdr import default_registry
from zros.closing import Closing
from zros.errors import ZrosError
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import NameFilter
from zros.gateway.foxglove.assets import Assets
from zros.gateway.foxglove.sdk import ServerOptions, import_sdk, ros2msg_schema
from zros.pubsub.taps import matched_qos

if TYPE_CHECKING:
    import foxglove
    from foxglove import Channel
    from foxglove.websocket import (
        ChannelView,
        Client,
        PlaybackControlRequest,
        PlaybackState,
        PlaybackStatus,
    )

    from zros.bag.read.source import Connection

_log = logging.getLogger('zros.gateway')

#: wall seconds between the server's time messages while playing
TIME_PERIOD = 0.05
#: bytes of latched messages kept for seeks (the rest are not sent again after a seek)
LATCHED_BYTES = 64 * 1024 * 1024


def _full_name(topic: str) -> str:
    return topic if topic.startswith('/') else '/' + topic


class BagGateway(Closing):
    """A Foxglove WebSocket server playing the bag at ``path`` (see the module docstring).

    It starts paused at the bag's first message; Foxglove's playback bar plays, pauses, seeks
    and changes the speed. ``topics`` and ``exclude`` select topics by regular expression.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        options: ServerOptions | None = None,
        *,
        topics: Iterable[str] | None = None,
        exclude: Iterable[str] | None = None,
        asset_paths: Iterable[str | os.PathLike[str]] = (),
    ) -> None:
        foxglove = import_sdk()
        from foxglove.websocket import Capability  # noqa: PLC0415 (optional: the foxglove extra)

        self.options = options or ServerOptions()
        selected = NameFilter.regexes(topics, exclude)
        assets = Assets(asset_paths) if asset_paths else None
        self.source = open_source(os.fspath(path))
        self._context = foxglove.Context()
        self._channels: dict[int, Channel] = {}  # by connection id
        by_topic: dict[str, Channel] = {}
        latched: list[Connection] = []
        types = BagTypes(self.source.path, self.source.connections)
        for connection in self.source.connections:
            name = _full_name(connection.topic)
            if not selected(name):
                continue
            if name not in by_topic:
                by_topic[name] = foxglove.Channel(
                    name,
                    schema=self._schema(connection, types),
                    message_encoding='cdr',
                    context=self._context,
                )
            self._channels[connection.id] = by_topic[name]
            if _latched(connection):
                latched.append(connection)
        if not self._channels:
            self.source.close()
            raise GatewayError(f'no topic of {path} is selected')
        self.connections = [c for c in self.source.connections if c.id in self._channels]
        self.start_ns, self.end_ns = self.source.start_ns, self.source.end_ns
        self._latched = self._read_latched(latched)
        self.clock = PlayClock(self.start_ns)
        self.clock.pause()
        self._lock = threading.Lock()
        self._seek_to: int | None = self.start_ns
        self._ended = False
        self._stopping = False
        self.published = 0  #: messages sent so far
        try:
            self._server, self._front = self.options.start(
                capabilities=[Capability.PlaybackControl, Capability.Time],
                playback_time_range=(self.start_ns, max(self.end_ns, self.start_ns + 1)),
                server_listener=_BagListener(self),
                asset_handler=assets.fetch if assets is not None else None,
                context=self._context,
            )
        except BaseException:
            self.source.close()
            raise
        self.port: int = self._front.port
        self.url = self.options.url(self.port)
        self._thread = threading.Thread(target=self._run, name='zros foxglove bag', daemon=True)
        self._thread.start()
        _log.info('Foxglove server on %s playing %s', self.url, self.source.path)

    def _schema(self, connection: Connection, types: BagTypes) -> foxglove.Schema | None:
        """The recording's own definition, unless its first message shows it wrong (as some
        recorders wrote them) and zros's registry has one that fits: then that one."""
        import foxglove  # noqa: PLC0415 (optional: the foxglove extra)

        if connection.definition and connection.definition_format in ('ros2msg', 'ros2idl'):
            recorded = foxglove.Schema(
                name=connection.type_name,
                encoding=connection.definition_format,
                data=connection.definition.encode(),
            )
            first = next(iter(self.source.messages([connection])), None)
            if first is None:
                return recorded
            try:
                types.decode(first)
            except ZrosError:
                return recorded  # nothing fits: the recording's definition is the best guess
            if types.message_class(connection) is not types.fallback.get_class(
                connection.type_name
            ):
                return recorded  # the recording's definition decodes its data
        return ros2msg_schema(default_registry(), connection.type_name)

    def _read_latched(self, connections: list[Connection]) -> list[RawMessage]:
        """The messages of latched topics, kept to send again after a seek: the last ones of
        each, as many as its publishers' depth, up to LATCHED_BYTES (then the latched topics
        are read no further). Streamed: what the depth drops is freed as the read goes."""
        if not connections:
            return []
        depth = {c.id: matched_qos(parse_qos_profiles(c.qos)).depth for c in connections}
        kept: dict[int, collections.deque[RawMessage]] = {
            c.id: collections.deque() for c in connections
        }
        size = 0
        for message in self.source.messages(connections):
            queue = kept[message.connection.id]
            full = len(queue) == depth[message.connection.id]
            grown = size + len(message.data) - (len(queue[0].data) if full else 0)
            if grown > LATCHED_BYTES:
                _log.warning('latched topics hold more than %d bytes: not all kept', LATCHED_BYTES)
                break
            size = grown
            if full:
                queue.popleft()
            if isinstance(message.data, bytes):
                queue.append(message)
            else:  # a view would keep its whole chunk alive
                queue.append(RawMessage(message.connection, message.timestamp, bytes(message.data)))
        return sorted((m for q in kept.values() for m in q), key=lambda m: m.timestamp)

    # --- playing -----------------------------------------------------------------------------

    def _interrupted(self) -> bool:
        return self._stopping or self._seek_to is not None

    def _run(self) -> None:
        messages: Iterator[RawMessage] = iter(())
        pending: RawMessage | None = None
        last_time = 0.0
        while not self._stopping:
            with self._lock:
                seek, self._seek_to = self._seek_to, None
            if seek is not None:
                messages = self.source.messages(self.connections, start=seek)
                pending = None
                self._send_latched(seek)
                self._server.broadcast_time(seek)
            if pending is None:
                pending = next(messages, None)
                if pending is None:
                    self._end()
                    continue
            step = min(
                pending.timestamp, self.clock.now() + round(TIME_PERIOD * 1e9 * self.clock.rate)
            )
            if not self.clock.sleep_until(step, self._interrupted):
                continue
            if time.monotonic() - last_time >= TIME_PERIOD:
                last_time = time.monotonic()
                self._server.broadcast_time(self.clock.now())
            if step >= pending.timestamp:
                self._send(pending)
                pending = None

    def _send(self, message: RawMessage) -> None:
        data = message.data
        self._channels[message.connection.id].log(
            data if isinstance(data, bytes) else bytes(data), log_time=message.timestamp
        )
        self.published += 1

    def _send_latched(self, position: int) -> None:
        for message in self._latched:
            if message.timestamp < position:
                self._send(message)

    def _end(self) -> None:
        """The last message went out: tell the clients, wait for a seek or a play."""
        from foxglove.websocket import PlaybackStatus  # noqa: PLC0415 (optional: the foxglove extra)

        with self._lock:
            self._ended = True
            self.clock.pause()
            self.clock.jump(self.end_ns)
        self._server.broadcast_time(self.end_ns)
        self._server.broadcast_playback_state(self._state(PlaybackStatus.Ended, False, None))
        self.clock.sleep_until(self.end_ns + 1, self._interrupted)

    def _state(
        self, status: PlaybackStatus, did_seek: bool, request_id: str | None
    ) -> PlaybackState:
        from foxglove.websocket import PlaybackState  # noqa: PLC0415 (optional: the foxglove extra)

        return PlaybackState(
            status=status,
            current_time=self.clock.now(),
            playback_speed=self.clock.rate,
            did_seek=did_seek,
            request_id=request_id,
        )

    def control(self, request: PlaybackControlRequest) -> PlaybackState:
        """Carry out a client's playback request (play, pause, speed, seek); the new state."""
        from foxglove.websocket import PlaybackCommand, PlaybackStatus  # noqa: PLC0415 (optional: the foxglove extra)

        with self._lock:
            seek = request.seek_time
            if seek is None and self._ended and request.playback_command == PlaybackCommand.Play:
                seek = self.start_ns  # play at the end starts again
            if seek is not None:
                seek = min(max(int(seek), self.start_ns), self.end_ns)
                self._seek_to = seek
                self._ended = False
                self.clock.jump(seek)
            if request.playback_speed > 0:
                self.clock.set_rate(float(request.playback_speed))
            if request.playback_command == PlaybackCommand.Play and not self._ended:
                self.clock.resume()
                status = PlaybackStatus.Playing
            else:
                self.clock.pause()
                status = PlaybackStatus.Ended if self._ended else PlaybackStatus.Paused
            self.clock.interrupt()
            return self._state(status, request.seek_time is not None, request.request_id)

    # --- the user's side -----------------------------------------------------------------------

    @property
    def channels(self) -> dict[str, str]:
        """The topics offered as channels, and their types."""
        return {c.topic: c.type_name for c in self.connections}

    def close(self) -> None:
        """Stop playing and serving, and close the bag."""
        if self._stopping:
            return
        self._stopping = True
        self.clock.interrupt()
        self._thread.join(5.0)
        self._front.close()
        self._server.stop()
        self.source.close()

    def __repr__(self) -> str:
        return f'<zros BagGateway {self.url} playing {self.source.path}>'


def _latched(connection: Connection) -> bool:
    try:
        offered = parse_qos_profiles(connection.qos)
    except ValueError:
        return False
    return bool(offered) and all(q.transient_local for q in offered)


class _BagListener:
    """The SDK's server listener of a bag server: playback requests (the SDK reports
    subscriptions too; the player sends every selected topic anyway)."""

    def __init__(self, gateway: BagGateway) -> None:
        self._gateway = gateway

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        """Nothing to do: every channel is played."""

    def on_unsubscribe(self, client: Client, channel: ChannelView) -> None:
        """Nothing to do: every channel is played."""

    def on_playback_control_request(
        self, playback_control_request: PlaybackControlRequest
    ) -> PlaybackState | None:
        try:
            return self._gateway.control(playback_control_request)
        except Exception:  # a client's request: logged, never raised into the SDK
            _log.exception('a playback request failed')
            return None

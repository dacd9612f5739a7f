"""A plain WebSocket client speaking rosbridge by hand, for the tests."""

from __future__ import annotations

import json
import ssl
import threading
import time
from collections.abc import Callable
from typing import Any

TIMEOUT = 20.0


class RawClient:
    """A connection whose received messages (decoded JSON, CBOR as dicts, text kept) are
    kept in order; :meth:`wait` finds one by predicate. ``origin``: the ``Origin`` header a
    browser on a page of that origin would send (none by default, as programs)."""

    def __init__(
        self, url: str, ca: str | None = None, read: bool = True, origin: str | None = None
    ) -> None:
        from websockets.sync.client import connect

        context = None
        if ca is not None:
            context = ssl.create_default_context(cafile=ca)
        # entered as a context manager, which websockets asks of its connections (17.1)
        self.connection = connect(
            url, ssl=context, max_size=None, open_timeout=TIMEOUT, origin=origin
        ).__enter__()
        self.received: list[dict[str, Any]] = []
        self.frames: list[str | bytes] = []
        self._arrived = threading.Condition()
        self._reader: threading.Thread | None = None
        if read:
            self.start()

    def start(self) -> None:
        """Start reading (a client that does not read yet stands for a slow one)."""
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        from websockets.exceptions import ConnectionClosed

        try:
            for frame in self.connection:
                if isinstance(frame, bytes):
                    import cbor2

                    message = cbor2.loads(frame)
                else:
                    message = json.loads(frame)
                with self._arrived:
                    self.frames.append(frame)
                    self.received.append(message)
                    self._arrived.notify_all()
        except ConnectionClosed:
            pass
        with self._arrived:
            self.received.append({'op': '<closed>'})
            self._arrived.notify_all()

    def send(self, **message: Any) -> None:
        """Send one protocol message."""
        self.connection.send(json.dumps(message))

    def mark(self) -> int:
        """The index of the next message (wait for what comes after an action)."""
        with self._arrived:
            return len(self.received)

    def wait(
        self,
        predicate: Callable[[dict[str, Any]], bool],
        timeout: float = TIMEOUT,
        start: int = 0,
    ) -> dict[str, Any]:
        """The first message from index ``start`` on for which ``predicate`` holds."""
        deadline = time.monotonic() + timeout
        with self._arrived:
            index = start
            while True:
                while index < len(self.received):
                    message = self.received[index]
                    index += 1
                    if predicate(message):
                        return message
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    recent = [str(m)[:200] for m in self.received[-5:]]
                    raise AssertionError(f'no such message within {timeout} s; the last: {recent}')
                self._arrived.wait(remaining)

    def of(self, op: str, **fields: Any) -> list[dict[str, Any]]:
        """Every message of one op (with these field values) so far."""
        with self._arrived:
            return [
                m
                for m in self.received
                if m.get('op') == op and all(m.get(k) == v for k, v in fields.items())
            ]

    def status(self, text: str, start: int = 0) -> dict[str, Any]:
        """The first status message containing ``text``."""
        return self.wait(lambda m: m.get('op') == 'status' and text in m['msg'], start=start)

    def close(self) -> None:
        self.connection.close()

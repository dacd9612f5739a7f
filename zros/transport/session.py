"""Zenoh sessions of the process: opened on demand, shared by nodes, always closed at exit.

Zenoh runs each callback subscriber on a Python thread of its own, which Python joins at exit
before ``atexit`` handlers run: a script that forgets ``shutdown()`` would hang. Sessions are
therefore closed from a ``threading`` exit hook, which runs before those joins. That thread is a
daemon when the thread that declared the subscriber was one (a recorder's discovery thread, say),
and Python does not join daemons: one still on its way out when the interpreter finalizes is
stopped inside Zenoh's Rust code, which aborts the process (``FATAL: exception not rethrown``).
The hook therefore also waits for those threads, which end once their sessions are closed, for
zros's own delivery threads (``zros.transport.delivery``, daemons too), which end the same way,
and for the threads given to :func:`join_at_exit` (an action goal's, which replies and publishes
its status once its callback returns, maybe as the script ends).
"""

from __future__ import annotations

import atexit
import collections
import contextlib
import logging
import threading
import time
import weakref
from collections.abc import Callable
from typing import TYPE_CHECKING

from zros.closing import Closing
from zros.transport import delivery
from zros.transport.config import SessionDefaults, TransportConfig, listen_endpoints
from zros.transport.credentials import password_dictionary
from zros.transport.endpoints import parse_endpoint
from zros.transport.errors import TransportError, zenoh_reason
from zros.transport.tlsfiles import check_tls_files

if TYPE_CHECKING:
    import zenoh

_log = logging.getLogger('zros.transport')


_open: weakref.WeakSet[Transport] = weakref.WeakSet()
_lock = threading.Lock()
_hook_installed = False


#: how Python names the thread Zenoh starts for a callback (its target is a PyO3 closure)
_CALLBACK_THREAD = '(pyo3-closure)'
#: how long the exit hook waits for such threads, all together (one may still run user code)
_CALLBACK_JOIN_TIMEOUT = 5.0


#: seconds between warnings of a session that opened without reaching its router
UNREACHED_WARNING_PERIOD = 10.0
#: outages whose times a session keeps (:meth:`Transport.outage_spans`)
OUTAGE_HISTORY = 1000

#: the warning of a lost link (a command whose error says so already filters it out)
LINK_LOST = 'lost the link to %s %s; Zenoh reconnects by itself, entities stay declared'

#: daemon threads of zros that call into Zenoh (goals' threads, say): the exit hook waits for them
_joined_at_exit: weakref.WeakSet[threading.Thread] = weakref.WeakSet()


def join_at_exit(thread: threading.Thread) -> None:
    """Have the exit hook wait (up to a few seconds, once the sessions are closed) for
    ``thread``, a daemon that calls into Zenoh: one still inside Zenoh's Rust code when the
    interpreter finalizes aborts the process (``FATAL: exception not rethrown``)."""
    _install_exit_hook()
    _joined_at_exit.add(thread)


def _close_all() -> None:
    for transport in list(_open):
        transport.close()
    deadline = time.monotonic() + _CALLBACK_JOIN_TIMEOUT
    for thread in threading.enumerate():
        if thread.daemon and (
            thread in _joined_at_exit
            or thread.name.endswith((_CALLBACK_THREAD, delivery.THREAD_SUFFIX))
        ):
            thread.join(max(0.0, deadline - time.monotonic()))


def _install_exit_hook() -> None:
    global _hook_installed  # noqa: PLW0603
    with _lock:
        if not _hook_installed:
            register = getattr(threading, '_register_atexit', None)
            if register is not None:
                register(_close_all)
            else:  # pragma: no cover - CPython has it since 3.9
                atexit.register(_close_all)
            _hook_installed = True


def _explain(error: Exception, config: TransportConfig) -> TransportError:
    from zros.transport.diagnose import explain_unreachable  # noqa: PLC0415 (ssl only on failure)

    text = zenoh_reason(error, config.secrets())
    # a peer's failed TLS handshake surfaces as the alert alone ("received fatal alert: ...")
    if any(word in text.lower() for word in ('connect', 'alert', 'certificate', 'handshake')):
        diagnosis = explain_unreachable(config)
        where = f'cannot reach a Zenoh router or bridge at {config.describe()}: '
        api, cli = f'{where}{diagnosis.api or text}', f'{where}{diagnosis.cli or text}'
        if diagnosis.unreachable or not diagnosis.reasons:
            api += (
                ". Start zenoh-bridge-ros2dds (or zenohd) there, or pass connect='tcp/<host>:7447'."
            )
            cli += (
                '. Start zenoh-bridge-ros2dds (or zenohd) there, or point zros '
                'elsewhere with --connect or ZROS_CONNECT=tcp/<host>:7447.'
            )
        failure = TransportError(api)
        failure.command_line = cli
        return failure
    return TransportError(f'cannot open a Zenoh session to {config.describe()}: {text}')


def _listen_hosts(config: TransportConfig, listening: list[str]) -> list[str] | None:
    """The hosts other peers dial to reach ``listening``, which the certificate must name
    (None: nothing listens; wildcard addresses stand for addresses not known here)."""
    if not listening:
        return None
    if config.tls is not None and not config.tls.verify_name:
        return []
    parsed = [parse_endpoint(endpoint) for endpoint in listening]
    return [e.host for e in parsed if e.port is not None and e.host not in ('0.0.0.0', '::')]


class Transport(Closing):
    """One open Zenoh session and what zros keeps per session (liveliness tokens)."""

    def __init__(self, config: TransportConfig | None = None) -> None:
        import zenoh  # noqa: PLC0415 (lazy: Zenoh, only for a session)

        self.config = config or TransportConfig.create()
        zenoh_config = self.config.to_zenoh()
        listening = listen_endpoints(zenoh_config)
        tls = self.config.tls
        if tls is not None:
            hosts = _listen_hosts(self.config, listening)
            check_tls_files(tls.root_ca_certificate, tls.certificate, tls.private_key, hosts)
        user = self.config.user if listening else None
        try:
            with password_dictionary(zenoh_config, user, self.config.password):
                #: the open ``zenoh.Session``, for what zros does not wrap (raw Zenoh, admin space)
                self.session: zenoh.Session = zenoh.open(zenoh_config)
        except zenoh.ZError as exc:
            raise _explain(exc, self.config) from None
        self.zid = str(self.session.zid())  #: the session's Zenoh id (hex)
        self._tokens: dict[str, tuple[zenoh.LivelinessToken, int]] = {}
        self._token_lock = threading.Lock()
        #: told of each token this session declares or undeclares, as it happens
        self._token_listeners: list[Callable[[str, bool], object]] = []
        self._closed = False
        self._close_callbacks: list[Callable[[], object]] = []
        self.links_lost = 0  #: how often a link to a router or peer went down
        self.outages = 0  #: how often the session lost its last link (see ``downtime``)
        self._down_since: float | None = None
        self._down_seconds = 0.0
        #: the newest outages as [start, end] in system time (ns), end None while it lasts
        self._outage_spans: collections.deque[tuple[int, int | None]] = collections.deque(
            maxlen=OUTAGE_HISTORY
        )
        self._links: set[str] = {str(z) for z in self.session.info.routers_zid()}
        self._link_changed = threading.Condition()
        self._link_listener = self.session.info.declare_transport_events_listener(
            self._on_transport_event, history=False
        )
        self._stopped = threading.Event()
        if self.config.connect is not None and not self.config.wait_for_router:
            threading.Thread(
                target=self._warn_while_unreached, name='zros-router-watch', daemon=True
            ).start()
        _install_exit_hook()
        _open.add(self)

    def _warn_while_unreached(self) -> None:
        """With ``wait_for_router=False``: while no link is up, say why, at most every 10 s."""
        from zros.transport.diagnose import explain_unreachable  # noqa: PLC0415 (ssl only here)

        while not self._stopped.is_set():
            if not self._links:
                reason = explain_unreachable(self.config).api or 'no link came up'
                if not self._links and not self._stopped.is_set():
                    _log.warning(
                        'session %s has not reached %s (Zenoh keeps trying): %s',
                        self.zid,
                        self.config.describe(),
                        reason,
                    )
            self._stopped.wait(UNREACHED_WARNING_PERIOD)

    @property
    def closed(self) -> bool:
        """Whether the session was closed."""
        return self._closed

    @property
    def connected(self) -> bool:
        """Whether the session has a link to a router or peer right now."""
        return bool(self._links)

    @property
    def downtime(self) -> float:
        """Seconds spent without any link after having one (the ``outages``), so far."""
        down_since = self._down_since
        ongoing = 0.0 if down_since is None else time.monotonic() - down_since
        return self._down_seconds + ongoing

    def outage_spans(self) -> list[tuple[int, int | None]]:
        """When the ``outages`` were (the newest 1000): ``(start, end)`` in system time, integer
        nanoseconds; ``end`` is None for the one going on."""
        with self._link_changed:
            return list(self._outage_spans)

    def _on_transport_event(self, event: zenoh.TransportEvent) -> None:
        import zenoh  # noqa: PLC0415 (lazy: Zenoh, only for a session)

        zid = str(event.transport.zid)
        role = str(event.transport.whatami).split('.')[-1].lower()
        lost = event.kind == zenoh.SampleKind.DELETE
        with self._link_changed:  # the count first: a waiter woken by the loss reads it
            restored = not lost and self.links_lost > 0 and zid not in self._links
            if lost:
                if not self._closed:
                    self.links_lost += 1
                self._links.discard(zid)
                if not self._closed and not self._links and self._down_since is None:
                    self.outages += 1
                    self._down_since = time.monotonic()
                    self._outage_spans.append((time.time_ns(), None))
            else:
                self._links.add(zid)
                down_since = self._down_since
                if down_since is not None:
                    self._down_seconds += time.monotonic() - down_since
                    self._down_since = None
                    start, _ = self._outage_spans.pop()
                    self._outage_spans.append((start, time.time_ns()))
            self._link_changed.notify_all()
        # a session no node uses (all destroyed; the process's stays open until shutdown)
        # loses nothing anyone waits for: its link is news only at debug level
        level = logging.WARNING if self._tokens else logging.DEBUG
        if lost and not self._closed:
            _log.log(level, LINK_LOST, role, zid)
        elif restored:
            _log.log(level, 'link to %s %s is up again', role, zid)

    def link_problem(self) -> str | None:
        """Why nothing can cross the network now: the session lost its last link (or, opened
        with ``wait_for_router=False``, has not reached its router yet); None while a link is
        up, and for a session that has never had to reach anything."""
        if self._links or self._closed:
            return None
        where = f'the router at {self.config.describe()}'
        if self.links_lost:
            return f'the link to {where} was lost (zros reconnects when the router is back)'
        if self.config.connect is not None and not self.config.wait_for_router:
            return f'{where} has not been reached yet (Zenoh keeps trying)'
        return None

    def wait_unlinked(self, timeout: float) -> bool:
        """Wait until the session has no link; returns whether it has none. Zenoh ends the
        queries that crossed a link as the link drops, a moment before zros hears of the drop."""
        with self._link_changed:
            return self._link_changed.wait_for(lambda: not self._links, timeout)

    def declare_token(self, key: str) -> None:
        """Declare a liveliness token, or count one more user of a token already declared.

        A bridge keys its routes by (session, key): two tokens for the same key from one
        session would collapse into one route, and retiring either would retire it.
        """
        with self._token_lock:  # listeners hear in the order tokens come and go
            token, users = self._tokens.get(key, (None, 0))
            if token is None:
                token = self.session.liveliness().declare_token(key)
                for listener in self._token_listeners:
                    listener(key, True)
            self._tokens[key] = (token, users + 1)

    def release_token(self, key: str) -> None:
        """Drop one user of a token; the token is undeclared with its last user."""
        with self._token_lock:
            token, users = self._tokens.get(key, (None, 0))
            if token is None:
                return
            if users > 1:
                self._tokens[key] = (token, users - 1)
                return
            del self._tokens[key]
            for listener in self._token_listeners:
                listener(key, False)
        if not self._closed:
            token.undeclare()  # type: ignore[no-untyped-call]  # untyped in zenoh's stub

    def on_token(self, listener: Callable[[str, bool], object]) -> None:
        """Call ``listener(key, alive)`` for each token this session holds now, then as it
        declares or undeclares one (under the session's token lock: a listener must not declare
        tokens): its own graph knows its own entities at once, as rclpy's does, not a moment
        later when Zenoh hands the tokens back."""
        with self._token_lock:
            self._token_listeners.append(listener)
            for key in self._tokens:
                listener(key, True)

    def remove_on_token(self, listener: Callable[[str, bool], object]) -> None:
        """Forget a listener given to :meth:`on_token`."""
        with self._token_lock, contextlib.suppress(ValueError):
            self._token_listeners.remove(listener)

    def on_close(self, callback: Callable[[], object]) -> None:
        """Call ``callback()`` before the session closes (entities undeclare themselves)."""
        self._close_callbacks.append(callback)

    def remove_on_close(self, callback: Callable[[], object]) -> None:
        """Forget a callback given to :meth:`on_close` (its owner went first)."""
        with contextlib.suppress(ValueError):
            self._close_callbacks.remove(callback)

    def close(self) -> None:
        """Undeclare everything and close the session; safe to call twice."""
        if self._closed:
            return
        self._stopped.set()
        for callback in reversed(list(self._close_callbacks)):  # they may remove themselves
            try:
                callback()
            except Exception:  # closing must go on whatever one entity does
                _log.exception('error while closing an entity of session %s', self.zid)
        self._closed = True
        _open.discard(self)
        self._tokens.clear()
        self.session.close()  # type: ignore[no-untyped-call]  # untyped in zenoh's stub

    def __repr__(self) -> str:
        state = 'closed' if self._closed else self.config.describe()
        return f'<zros Transport {self.zid} ({state})>'


_default: Transport | None = None
_default_lock = threading.Lock()


def default_transport(
    config: TransportConfig | None = None, *, defaults: SessionDefaults | None = None
) -> Transport:
    """The process-wide session, opened on first use (with ``config`` if given then, else
    the environment's settings over ``defaults``, a wire scheme's session defaults)."""
    global _default  # noqa: PLW0603
    with _default_lock:
        if _default is None or _default.closed:
            if config is None and defaults is not None:
                config = TransportConfig.create(defaults=defaults)
            _default = Transport(config)
        elif config is not None and config != _default.config:
            raise TransportError(
                'the process already has a Zenoh session with other settings; close it first '
                '(zros.shutdown()) or pass transport= to use a second one'
            )
        return _default


def close_default_transport() -> None:
    """Close the process-wide session, if open."""
    global _default  # noqa: PLW0603
    with _default_lock:
        if _default is not None:
            _default.close()
            _default = None

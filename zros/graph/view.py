"""A live view of the ROS graph, built from the liveliness tokens on the Zenoh network.

Each wire scheme announces its nodes and entities with tokens of its own; the view holds one
:class:`~zros.wire.TokenView` per scheme of :data:`zros.wire.SCHEMES`, which follows that
scheme's tokens (the bridges' ``@ros2_lv`` and zros's ``@zros_lv`` owner tokens; rmw_zenoh's
``@ros2_lv/<domain>/...``) and answers as endpoints and node names. The view follows tokens as
they come and go (a closed session's tokens go within milliseconds, a vanished one's within the
Zenoh lease); an endpoint's ``wire`` says which scheme announced it.
"""

from __future__ import annotations

import functools
import logging
import threading
import time
from collections.abc import Callable

from zenoh import KeyExpr, SampleKind, ZError
from zenoh.handlers import FifoChannel

from zros.keyexpr.kinds import EntityKind
from zros.runtime.entity import Undeclarable
from zros.runtime.signal import Signal
from zros.transport import Transport
from zros.transport.per_session import PerSession
from zros.transport.session import join_at_exit
from zros.wire import SCHEMES, BridgeInfo, Endpoint, TokenView, wire_class
from zros.wire.tokens import LocalToken, TokenHandler, TokenSample

_log = logging.getLogger('zros.graph')

#: replies one graph refresh can hold per selector (tokens of a very large graph)
REFRESH_CAPACITY = 1_000_000
#: seconds a refresh's asks may wait for the network's answer: an answer ends an ask at once, so
#: this only bounds a router slow to answer (a loaded machine took over 2 s)
ANSWER_WITHIN = 15.0
#: seconds after which Zenoh's echo of a token this session undeclared is no longer expected
ECHOES_WITHIN = 30.0
#: own tokens remembered before those gone for ECHOES_WITHIN are forgotten
_OWN_KEPT = 256

__all__ = ['ANSWER_WITHIN', 'ECHOES_WITHIN', 'REFRESH_CAPACITY', 'Endpoint', 'Graph', 'graph_of']


class Graph:
    """What one session sees of the ROS graph; updated by Zenoh as tokens come and go."""

    def __init__(self, transport: Transport) -> None:
        session = self._session = transport.session
        self._changed = Signal()
        self.version = 0  #: bumped on every change
        self._closed = False
        #: what it hears of each scheme, by the scheme's name
        self._views: dict[str, TokenView] = {
            name: wire_class(name).token_view(session, self._bump) for name in SCHEMES
        }
        #: this session's own tokens, heard from the session itself (:meth:`_own_token`): None
        #: while declared, else when it was undeclared (Zenoh's echoes of them are ignored)
        self._ours: dict[str, float | None] = {}
        self._own_lock = threading.Lock()
        #: while asks run (how many), the tokens heard gone since the first began: a reply
        #: that crossed their undeclaration must not bring them back
        self._asking = 0
        self._gone_while_asking: set[str] = set()
        #: what the views follow: a key expression each, and the view's handler of its tokens
        self._selectors = [pair for view in self._views.values() for pair in view.selectors()]
        self._matchers = [(KeyExpr(selector), handler) for selector, handler in self._selectors]
        liveliness = session.liveliness()
        # news only (no history): while a subscriber's history was on its way, Zenoh answered
        # a liveliness query of the session from what it had heard so far, at once and short
        # (33 of 100 refreshes under two CPU hogs; 0 of 100 without history). The tokens
        # present now come from asking, as refresh does, on a thread: nothing waits for them
        self._subscribers: list[Undeclarable] = [
            liveliness.declare_subscriber(selector, self._heard(handler), history=False)
            for selector, handler in self._selectors
        ]
        self._transport = transport
        transport.on_token(self._own_token)  # the tokens it holds now too
        transport.on_close(self.close)
        self._filled = threading.Event()  #: the tokens present at the start were asked for
        filling = threading.Thread(target=self._fill, name='zros-graph-fill', daemon=True)
        join_at_exit(filling)
        filling.start()

    def _heard(self, handler: TokenHandler) -> TokenHandler:
        """``handler``, deaf to Zenoh's echo of this session's own tokens: a late echo of a
        token already undeclared would bring it back until the echo of its undeclaration."""
        return functools.partial(self._unless_ours, handler)

    def _unless_ours(self, handler: TokenHandler, sample: TokenSample) -> None:
        key = str(sample.key_expr)
        with self._own_lock:
            if key in self._ours:
                return  # an echo (one from the session, one through the router for a client)
            if self._asking and sample.kind == SampleKind.DELETE:
                self._gone_while_asking.add(key)
        handler(sample)

    def _unless_gone(self, handler: TokenHandler, reply: TokenSample) -> None:
        """``handler`` for a reply to an ask, unless its token was heard gone meanwhile."""
        with self._own_lock:
            if str(reply.key_expr) in self._gone_while_asking:
                return
        self._unless_ours(handler, reply)

    def _own_token(self, key: str, alive: bool) -> None:
        """A token of this session, known at once, as rclpy knows its node's own entities (Zenoh
        hands it back a moment later: :meth:`_heard` ignores that echo)."""
        if self._closed:
            return
        now = time.monotonic()
        with self._own_lock:
            self._ours[key] = None if alive else now
            if len(self._ours) > _OWN_KEPT:  # forget tokens gone long enough for every echo
                for gone in [k for k, at in self._ours.items() if at and now - at > ECHOES_WITHIN]:
                    del self._ours[gone]
        sample = LocalToken(key, SampleKind.PUT if alive else SampleKind.DELETE)
        expression = KeyExpr(key)
        for selector, handler in self._matchers:
            if selector.intersects(expression):
                handler(sample)

    def _bump(self) -> None:
        self.version += 1
        if self._changed:
            self._changed.notify()

    def _fill(self) -> None:
        """Ask for the tokens present when the view opened (the subscribers hear news only)."""
        try:
            self._ask(ANSWER_WITHIN)
        except ZError:  # the session closed first
            _log.debug('the graph of a closed session was not filled', exc_info=True)
        finally:
            self._filled.set()

    def wait_filled(self, timeout: float) -> bool:
        """Wait until the tokens present when the view opened have been asked for (until then
        it knows only what it heard since); whether they have. Not on a Zenoh callback thread:
        the answer may have to come through it."""
        return self._filled.wait(timeout)

    def _ask(self, within: float) -> None:
        """Ask the network for every token the views follow, one selector after another, each
        ask ending when the network has answered (at the latest after ``within`` seconds)."""
        liveliness = self._session.liveliness()
        with self._own_lock:
            self._asking += 1
        try:
            for selector, handler in self._selectors:
                if self._closed:
                    return
                heard = functools.partial(self._unless_gone, handler)
                # a FIFO of Zenoh's default size (256) that fills while this thread takes the
                # GIL back from the graph's callbacks stalls the session: room for any graph
                replies = liveliness.get(
                    selector, handler=FifoChannel(REFRESH_CAPACITY), timeout=within
                )
                for reply in replies:
                    if reply.ok is not None:
                        heard(reply.ok)
        finally:
            with self._own_lock:
                self._asking -= 1
                if not self._asking:
                    self._gone_while_asking.clear()

    def refresh(self, timeout: float = 2.0) -> None:
        """Ask the network for every token now, and wait up to ``timeout`` seconds more until
        bridges told their version.

        The view fills by itself shortly after a session opens; a command-line tool that looks
        once calls this to see the whole graph at once. The asks end when the network has
        answered them (at once, normally), within :data:`ANSWER_WITHIN` seconds.
        """
        # one after another, each with the whole time: with one budget for all, a slow first
        # answer on a loaded machine left the last ones 50 ms; asked all at once, some answers
        # came back short under load (2 of 12 `zros action info` missed the node's name)
        self._ask(max(timeout, ANSWER_WITHIN))
        self.wait_until(lambda: all(view.settled() for view in self._views.values()), timeout)

    # --- queries ------------------------------------------------------------------------------

    def endpoints(self, kinds: tuple[EntityKind, ...] | None = None) -> list[Endpoint]:
        """Every endpoint known, optionally of some kinds only."""
        result = [
            endpoint
            for view in self._views.values()
            for endpoint in view.endpoints()
            if kinds is None or endpoint.kind in kinds
        ]
        return sorted(result, key=lambda e: (e.key, e.kind.value, e.zid))

    def _names(
        self, kinds: tuple[EntityKind, ...], namespace: str, node: str | None = None
    ) -> dict[str, list[str]]:
        names: dict[str, set[str]] = {}
        for endpoint in self.endpoints(kinds):
            if node is None or endpoint.node == node:
                names.setdefault(endpoint.ros_name(namespace), set()).add(endpoint.type_name)
        return {name: sorted(types) for name, types in sorted(names.items())}

    def node_names(
        self, node_fqn: str, kinds: tuple[EntityKind, ...], namespace: str = '/'
    ) -> dict[str, list[str]]:
        """The names and types of a node's endpoints of ``kinds`` (zros and rmw_zenoh nodes:
        a bridge does not say which ROS node owns what it announces)."""
        return self._names(kinds, namespace, node_fqn)

    def topics(self, namespace: str = '/') -> dict[str, list[str]]:
        """Topic names (as seen through a bridge with ``namespace``) and their types."""
        return self._names((EntityKind.PUBLISHER, EntityKind.SUBSCRIBER), namespace)

    def services(self, namespace: str = '/') -> dict[str, list[str]]:
        """Service names and types (servers or clients announced)."""
        return self._names((EntityKind.SERVICE_SERVER, EntityKind.SERVICE_CLIENT), namespace)

    def actions(self, namespace: str = '/') -> dict[str, list[str]]:
        """Action names and types (servers or clients announced; under rmw_zenoh, found by
        their ``send_goal`` services as ROS finds them)."""
        names = self._names((EntityKind.ACTION_SERVER, EntityKind.ACTION_CLIENT), namespace)
        suffix = '/_action/send_goal'
        for name, types in self.services(namespace).items():
            if name.endswith(suffix):
                found = [t[: -len('_SendGoal')] for t in types if t.endswith('_SendGoal')]
                if found:
                    action = names.setdefault(name[: -len(suffix)], [])
                    action[:] = sorted(set(action) | set(found))
        return dict(sorted(names.items()))

    def publishers(self, key: str) -> list[Endpoint]:
        """The publishers announced on a Zenoh key."""
        return [e for e in self.endpoints((EntityKind.PUBLISHER,)) if e.key == key]

    def subscribers(self, key: str) -> list[Endpoint]:
        """The subscribers announced on a Zenoh key."""
        return [e for e in self.endpoints((EntityKind.SUBSCRIBER,)) if e.key == key]

    def bridges(self) -> list[BridgeInfo]:
        """The bridges present, with their version and namespace once they answered."""
        return sorted(
            (bridge for view in self._views.values() for bridge in view.bridges()),
            key=lambda b: b.zid,
        )

    def nodes(self) -> list[str]:
        """Fully qualified names of the nodes announced (zros nodes, rmw_zenoh nodes) and of
        the bridges' ROS nodes."""
        return sorted(set().union(*(view.nodes() for view in self._views.values())))

    def node_instances(self) -> list[str]:
        """:meth:`nodes`, once per node: a name two nodes share is there twice (as ``ros2 node
        list`` shows it). Two zros nodes of one name in one bridge-wire session are one."""
        return sorted(name for view in self._views.values() for name in view.node_instances())

    def wires(self) -> list[str]:
        """The wire schemes present on the network: ``'bridge'`` (bridges, or zros nodes
        speaking to bridges) and ``'rmw_zenoh'`` (nodes running rmw_zenoh, zros ones included)."""
        return sorted(name for name, view in self._views.items() if view.present())

    def node_endpoints(self, node_fqn: str) -> list[Endpoint]:
        """What a zros node announced (its publishers, subscribers, services...)."""
        return [e for e in self.endpoints() if e.node == node_fqn]

    def wait_until(
        self,
        predicate: Callable[[], object],
        timeout: float | None = None,
        *,
        interruptible: bool = True,
    ) -> bool:
        """Wait until ``predicate()`` is true, re-checking at every change of the graph;
        whether it became true (False on timeout, once closed, and after Ctrl-C unless not
        ``interruptible``)."""
        self._changed.wait_for(lambda: predicate() or self._closed, timeout, interruptible)
        return bool(predicate())

    @property
    def closed(self) -> bool:
        """Whether it stopped following the network (its session closed)."""
        return self._closed

    def close(self) -> None:
        """Stop following the network's announcements."""
        if self._closed:
            return
        self._closed = True
        self._transport.remove_on_token(self._own_token)
        for view in self._views.values():
            view.close()
        for subscriber in self._subscribers:
            try:
                subscriber.undeclare()
            except ZError:  # the session may be closing already
                _log.debug('undeclaring a graph subscriber failed', exc_info=True)
        self._changed.notify()


#: the graph of a session, made on first use and closed with it (shared by its nodes)
graph_of = PerSession(Graph)

"""The ``create_*`` methods of a node (rclpy's names and argument order: type, then name).

The classes they make take the name first (``zros.Subscriber(topic, type, node=None)``, rosR's
order), and the default node when ``node`` is not given: both ways are deliberate parity.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import cast, overload

from zros.actions import ActionClient, ActionServer, ServerGoalHandle
from zros.cdr import Message
from zros.cdr.interfaces import ActionType, ServiceType
from zros.cdr.message import M
from zros.pubsub import Publisher, Subscriber
from zros.pubsub.subscriber import T
from zros.qos import QoSLike
from zros.runtime.clock import Clock
from zros.runtime.context import NodeContext
from zros.runtime.entity import Entity
from zros.runtime.timers import Rate, Timer
from zros.services import Client, Service
from zros.services.server import ServiceHandler


class EntityFactories:
    """``create_publisher``, ``create_subscription``, ``create_service``... of a node."""

    context: NodeContext
    clock: Clock
    spin_until_clock: Callable[[int], None]

    @overload
    def create_publisher(
        self, msg_type: str, topic: str, qos: QoSLike | None = None
    ) -> Publisher[Message]: ...

    @overload
    def create_publisher(
        self, msg_type: type[M], topic: str, qos: QoSLike | None = None
    ) -> Publisher[M]: ...

    def create_publisher(
        self, msg_type: str | type[M], topic: str, qos: QoSLike | None = None
    ) -> Publisher[M] | Publisher[Message]:
        """A publisher on ``topic`` (rclpy's order; ``zros.Publisher(topic, type)`` is rosR's).
        A ``Publisher[String]`` for the class ``String``, a ``Publisher[Message]`` for a name."""
        if isinstance(msg_type, str):
            return Publisher(topic, msg_type, qos, node=self)
        return Publisher(topic, msg_type, qos, node=self)

    @overload
    def create_subscription(
        self,
        msg_type: str,
        topic: str,
        callback: Callable[[Message], object] | None = None,
        qos: QoSLike | None = None,
    ) -> Subscriber[Message]: ...

    @overload
    def create_subscription(
        self,
        msg_type: type[M],
        topic: str,
        callback: Callable[[M], object] | None = None,
        qos: QoSLike | None = None,
    ) -> Subscriber[M]: ...

    def create_subscription(
        self,
        msg_type: str | type[M],
        topic: str,
        callback: Callable[[M], object] | Callable[[Message], object] | None = None,
        qos: QoSLike | None = None,
    ) -> Subscriber[M] | Subscriber[Message]:
        """A subscriber on ``topic``; ``callback(message)`` runs when the node spins (rclpy's
        order; ``zros.Subscriber(topic, type)`` is rosR's). A ``Subscriber[String]`` for the
        class ``String`` (its callback takes a ``String``), a ``Subscriber[Message]`` for a name."""
        # the overloads tie callback to msg_type
        handler = cast('Callable[[Message], object] | None', callback)
        cls: str | type[Message] = msg_type
        return Subscriber(topic, cls, handler, qos, node=self)

    def create_service(
        self,
        srv_type: str | ServiceType,
        name: str,
        handler: ServiceHandler | None = None,
    ) -> Service:
        """A service server; ``handler(request)`` returns the response (see ``zros.Service``)."""
        return Service(name, srv_type, handler, node=self)

    def create_client(
        self, srv_type: str | ServiceType, name: str, timeout: float = 10.0
    ) -> Client:
        """A service client; ``client.call(request)`` returns the response."""
        return Client(name, srv_type, node=self, timeout=timeout)

    def create_action_server(
        self,
        action_type: str | ActionType,
        name: str,
        execute_callback: Callable[[ServerGoalHandle], object],
        *,
        goal_callback: Callable[[Message], object] | None = None,
        cancel_callback: Callable[[ServerGoalHandle], object] | None = None,
        result_timeout: float = 900.0,
    ) -> ActionServer:
        """An action server; ``execute_callback(goal_handle)`` returns the result."""
        return ActionServer(
            name,
            action_type,
            execute_callback,
            goal_callback=goal_callback,
            cancel_callback=cancel_callback,
            node=self,
            result_timeout=result_timeout,
        )

    def create_action_client(self, action_type: str | ActionType, name: str) -> ActionClient:
        """An action client; ``client.send_goal(goal)`` returns a goal handle."""
        return ActionClient(name, action_type, node=self)

    def create_timer(self, period: float, callback: Callable[[], object]) -> Timer:
        """A timer calling ``callback()`` every ``period`` seconds while the node spins."""
        return Timer(period, callback, node=self)

    def create_rate(self, hz: float) -> Rate:
        """A rate whose ``sleep()`` runs this node's callbacks while it waits."""
        return Rate(hz, node=self)

    # --- rclpy's destroy_* : True when the entity was this node's and open, else False ------

    def _destroy(self, entity: Entity, kind: type[Entity]) -> bool:
        if not isinstance(entity, kind) or entity not in self.context.entities:
            return False
        entity.close()
        return True

    def destroy_publisher(self, publisher: Publisher[M]) -> bool:
        """Close a publisher of this node (rclpy's name); False if it was not one, or closed."""
        return self._destroy(publisher, Publisher)

    def destroy_subscription(self, subscription: Subscriber[T]) -> bool:
        """Close a subscriber of this node (rclpy's name); False if it was not one, or closed."""
        return self._destroy(subscription, Subscriber)

    def destroy_client(self, client: Client) -> bool:
        """Close a service client of this node (rclpy's name); False if not one, or closed."""
        return self._destroy(client, Client)

    def destroy_service(self, service: Service) -> bool:
        """Close a service server of this node (rclpy's name); False if not one, or closed."""
        return self._destroy(service, Service)

    def destroy_timer(self, timer: Timer) -> bool:
        """Cancel a timer of this node (rclpy's name); False if not one, or cancelled."""
        if not isinstance(timer, Timer) or timer.node is not self or timer.cancelled:
            return False
        timer.cancel()
        return True

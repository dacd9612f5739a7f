"""A generic rclpy worker driven by JSON lines: the real ROS 2 side of the interop tests.

Run as a script (it imports neither zros nor the tests package, so it also runs with the
system Python of the official ``ros:jazzy`` image)::

    python tests/interop/ros_worker.py                 # commands on stdin, replies on stdout
    python tests/interop/ros_worker.py --serve tcp:0.0.0.0:7501
                                                       # one worker per connection (docker)
    python tests/interop/ros_worker.py --serve unix:/tmp/worker.sock

Each command is one JSON object per line; each reply is one JSON line, ``{"ok": true, ...}`` or
``{"ok": false, "error": "..."}``. Serialized messages travel as hex strings (CDR header
included, exactly what rclpy publishes and receives with ``raw=True``).

=====================  ============================================================================
``publisher``          ``name, topic, type, qos`` -> create a publisher
``publish``            ``name, data: [hex...], interval`` -> publish the serialized messages
``wait_subscribers``   ``name, count, timeout`` -> ``count`` (matched DDS readers of the publisher)
``wait_publishers``    ``name, count, timeout`` -> ``count`` (matched DDS writers of the subscription)
``wait_readers``       ``topic, count, timeout`` -> ``count`` (DDS readers of any topic, hidden ones
                       too, in the ROS graph: rclpy ``count_subscribers``)
``subscription``       ``name, topic, type, qos`` -> create a raw subscription that records
``wait_messages``      ``name, count, timeout`` -> ``messages: [hex...]`` (all received so far)
``topics``             -> ``topics: [[name, [types...]], ...]`` (rclpy ``get_topic_names_and_types``)
``wait_topic``         ``topic, type, present, timeout`` -> ``topics`` once the topic is (not) there
``service``            ``name, service, type`` -> a server answering each request with a response
                       whose fields are copied from the request's fields of the same name
``call``               ``service, type, data: hex, timeout`` -> ``response: hex`` (a fresh client)
``action_server``      ``name, action, cancelable, abort_order, hold`` -> a
                       ``test_msgs/action/Fibonacci`` server (feedback per step; see below)
``action_call``        ``action, order, timeout, cancel_after_feedback, record,
                       feedback_count`` -> ``accepted, goal_id, status, sequence, feedback``
                       (a Fibonacci goal sent by a fresh ``ActionClient``; see below)
``param_node``         ``name, node, namespace, parameters, allow_undeclared`` -> a further rclpy
                       node (on the same executor) declaring ``parameters`` (see below); ``fqn``
``param_node_op``      ``name, op: declare|undeclare|set, parameters`` -> on that node itself:
                       ``declare`` (specs), ``undeclare`` (``name`` of each spec), ``set``
                       (``results``: one ``{successful, reason}`` per parameter)
``param_client``       ``name, node, timeout`` -> an rclpy ``AsyncParameterClient`` of the remote
                       node ``node``; ``ready`` once all six services are (or after ``timeout``)
``param_call``         ``name, op, timeout, ...`` -> one call of that client, see below
``param_events``       ``name, client`` -> record ``/parameter_events`` through
                       ``client.on_parameter_event`` (an ``AsyncParameterClient``'s subscription)
``wait_param_events``  ``name, node, count, timeout`` -> ``events`` (all those of ``node`` so
                       far, once there are ``count``)
``destroy``            ``name`` -> destroy that publisher, subscription, service or action server
                       (or parameter node, parameter client)
``exit``               -> stop
=====================  ============================================================================

``qos`` is ``{"reliability": "reliable"|"best_effort", "durability": "volatile"|
"transient_local", "history": "keep_last"|"keep_all", "depth": n}`` (all optional).

``action_server`` options (all optional; without them the server rejects cancel requests and
succeeds every goal after ``order - 1`` steps):

* ``cancelable``: accept cancel requests; a goal checks ``is_cancel_requested`` before each step
  and ends with ``canceled()``, its result the sequence so far;
* ``abort_order``: a goal of that order aborts right after its first step (and its feedback);
* ``hold``: seconds a goal waits after its first step for a cancel request (with
  ``cancelable``), so that a client can cancel it before it ends.

``action_call`` options (all optional):

* ``cancel_after_feedback``: once the first feedback arrived, cancel the goal; the reply gets
  ``cancel: {return_code, goals_canceling: [hex goal ids]}``;
* ``record``: also record the goal's feedback and states on the action's feedback and status
  topics, with subscriptions of their own (matched before the goal is sent). rclpy's
  ``ActionClient`` drops feedback it takes after the result (the result may overtake the last
  feedback: a topic and a reply), these do not. Once the result is in, wait (up to ``timeout``)
  for a terminal state and ``feedback_count`` feedback messages; the reply gets
  ``topic_feedback: [[int...]...]`` and ``statuses: [int...]`` (the goal's state in each
  ``GoalStatusArray``), in arrival order. (Not the goal handle's ``status``: rclpy ignores status
  arrays taken before the goal response, and through a bridge a fast goal's last status can
  overtake its goal response, so that status may stay UNKNOWN.)

Parameters travel as JSON: a value is ``{"type": n, "value": v}`` (``rcl_interfaces``
``ParameterType`` numbers; a byte array's value is a hex string, NOT_SET's null), a parameter
``{"name": s, "type": n, "value": v}``, a descriptor ``{"name", "type", "description",
"additional_constraints", "read_only", "dynamic_typing", "integer_range": [from, to, step] |
null, "floating_point_range": [...] | null}``, a parameter spec of ``param_node`` a parameter
with an optional ``descriptor`` (its optional fields; ``type`` comes from the value), an event
``{"node", "new": [parameter...], "changed": [...], "deleted": [...]}``.

``param_call`` ops and their replies: ``list`` (``prefixes, depth``) -> ``names, prefixes``;
``get`` (``names``) -> ``values``; ``types`` (``names``) -> ``types``; ``describe`` (``names``) ->
``descriptors``; ``set`` (``parameters``) -> ``results``; ``set_atomically`` (``parameters``) ->
``result``; ``delete`` (``names``) -> ``results``. A result is ``{"successful", "reason"}``.
"""

from __future__ import annotations

import importlib
import json
import os
import socket
import subprocess
import sys
import threading
import time
from typing import Any, TextIO

#: seconds the Fibonacci action server takes per step (so that feedback can be watched)
STEP = 0.05


def _message_class(type_name: str) -> Any:
    package, kind, short = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), short)


def _profile(spec: dict[str, Any] | None) -> Any:
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    spec = spec or {}
    history = HistoryPolicy.KEEP_ALL if spec.get('history') == 'keep_all' else None
    return QoSProfile(
        history=history or HistoryPolicy.KEEP_LAST,
        depth=int(spec.get('depth', 10)),
        reliability=ReliabilityPolicy.BEST_EFFORT
        if spec.get('reliability') == 'best_effort'
        else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL
        if spec.get('durability') == 'transient_local'
        else DurabilityPolicy.VOLATILE,
    )


#: ParameterValue field of each parameter type number (1 BOOL ... 9 STRING_ARRAY)
PARAMETER_FIELDS = {
    1: 'bool_value',
    2: 'integer_value',
    3: 'double_value',
    4: 'string_value',
    5: 'byte_array_value',
    6: 'bool_array_value',
    7: 'integer_array_value',
    8: 'double_array_value',
    9: 'string_array_value',
}


def _value_json(message: Any) -> dict[str, Any]:
    """``{"type", "value"}`` of an ``rcl_interfaces/msg/ParameterValue``."""
    kind = int(message.type)
    if kind not in PARAMETER_FIELDS:
        return {'type': kind, 'value': None}
    raw = getattr(message, PARAMETER_FIELDS[kind])
    if kind == 5:
        value: Any = b''.join(bytes(item) for item in raw).hex()
    elif kind > 5:
        value = [item.item() if hasattr(item, 'item') else item for item in raw]
    else:
        value = raw
    return {'type': kind, 'value': value}


def _python_value(spec: dict[str, Any]) -> Any:
    """The rclpy ``Parameter`` value of a JSON value (a byte array: a list of 1-byte bytes)."""
    kind = int(spec['type'])
    value: Any = spec.get('value')
    if kind == 0:
        return None
    if kind == 5:
        return [bytes([item]) for item in bytes.fromhex(value)]
    if kind == 3:
        return float(value)
    if kind == 8:
        return [float(item) for item in value]
    return value


def _parameter(spec: dict[str, Any]) -> Any:
    """An rclpy ``Parameter`` of a JSON parameter."""
    from rclpy.parameter import Parameter

    return Parameter(spec['name'], Parameter.Type(int(spec['type'])), _python_value(spec))


def _parameter_json(message: Any) -> dict[str, Any]:
    return {'name': message.name, **_value_json(message.value)}


def _result_json(result: Any) -> dict[str, Any]:
    return {'successful': bool(result.successful), 'reason': result.reason}


def _descriptor(spec: dict[str, Any]) -> Any:
    """An ``rcl_interfaces/msg/ParameterDescriptor`` from its JSON fields (all optional)."""
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

    descriptor = ParameterDescriptor(
        description=spec.get('description', ''),
        additional_constraints=spec.get('additional_constraints', ''),
        read_only=bool(spec.get('read_only', False)),
        dynamic_typing=bool(spec.get('dynamic_typing', False)),
    )
    if spec.get('integer_range'):
        low, high, step = spec['integer_range']
        descriptor.integer_range = [IntegerRange(from_value=low, to_value=high, step=step)]
    if spec.get('floating_point_range'):
        low, high, step = (float(item) for item in spec['floating_point_range'])
        descriptor.floating_point_range = [
            FloatingPointRange(from_value=low, to_value=high, step=step)
        ]
    return descriptor


def _descriptor_json(message: Any) -> dict[str, Any]:
    integer = message.integer_range[0] if len(message.integer_range) else None
    floating = message.floating_point_range[0] if len(message.floating_point_range) else None
    return {
        'name': message.name,
        'type': int(message.type),
        'description': message.description,
        'additional_constraints': message.additional_constraints,
        'read_only': bool(message.read_only),
        'dynamic_typing': bool(message.dynamic_typing),
        'integer_range': (
            [integer.from_value, integer.to_value, integer.step] if integer else None
        ),
        'floating_point_range': (
            [floating.from_value, floating.to_value, floating.step] if floating else None
        ),
    }


def _event_json(event: Any) -> dict[str, Any]:
    return {
        'node': event.node,
        'new': [_parameter_json(item) for item in event.new_parameters],
        'changed': [_parameter_json(item) for item in event.changed_parameters],
        'deleted': [_parameter_json(item) for item in event.deleted_parameters],
    }


class Worker:
    """One rclpy node executing commands."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.executors import MultiThreadedExecutor
        from rclpy.node import Node

        rclpy.init(args=[])
        self.rclpy = rclpy
        self.node = Node(f'zros_interop_worker_{os.getpid()}')
        # the node spins all the time (servers must answer between commands)
        self.executor = MultiThreadedExecutor(num_threads=4)
        self.executor.add_node(self.node)
        self.stopping = threading.Event()
        self.spinner = threading.Thread(target=self.spin, daemon=True)
        self.spinner.start()
        self.publishers: dict[str, Any] = {}
        self.subscriptions: dict[str, Any] = {}
        self.received: dict[str, list[bytes]] = {}
        self.others: dict[str, Any] = {}
        self.param_nodes: dict[str, Any] = {}
        self.param_clients: dict[str, Any] = {}
        self.param_events: dict[str, list[dict[str, Any]]] = {}

    def group(self) -> Any:
        """A callback group of its own for each entity with callbacks.

        In rclpy Jazzy the executor takes an entity's data before the ``try`` that ends the
        entity's turn in its callback group (``Executor._make_handler``): a take that raises,
        as an ``ActionClient`` destroyed while the executor takes its feedback does ("action
        client pointer is invalid"), leaves that group busy for good. Had every entity shared
        the node's default group, each later subscription and client of the worker would
        never run again (later tests saw "0 of 3 messages arrived", "send_goal got no
        response").
        """
        from rclpy.callback_groups import MutuallyExclusiveCallbackGroup

        return MutuallyExclusiveCallbackGroup()

    def spin(self) -> None:
        """``executor.spin()``, except that a callback that raises does not stop it.

        rclpy's ``ActionClient`` can raise a KeyError on an executor thread when a goal's last
        feedback and its result are taken together: a done callback of the result, run on
        another thread, removes the feedback callback between its check and its use (rclpy
        Jazzy, ``ActionClient.execute``). ``executor.spin()`` re-raises that, and a worker that
        stopped spinning would leave every later test waiting.
        """
        while not self.stopping.is_set() and self.rclpy.ok():
            try:
                self.executor.spin_once(timeout_sec=0.1)
            except Exception as exc:
                print(f'ros_worker: a callback raised {exc!r}', file=sys.stderr, flush=True)

    def spin_until(self, condition: Any, timeout: float) -> bool:
        """Wait (the node spins meanwhile) until ``condition()`` or ``timeout`` seconds pass."""
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() >= deadline:
                return bool(condition())
            time.sleep(0.005)
        return True

    def handle(self, command: dict[str, Any]) -> dict[str, Any]:
        op = command['cmd']
        name = command.get('name', '')
        if op == 'publisher':
            self.publishers[name] = self.node.create_publisher(
                _message_class(command['type']), command['topic'], _profile(command.get('qos'))
            )
            return {}
        if op == 'publish':
            publisher = self.publishers[name]
            interval = float(command.get('interval', 0.0))
            for item in command['data']:
                publisher.publish(bytes.fromhex(item))
                if interval:
                    self.spin_until(lambda: False, interval)
            return {}
        if op == 'wait_subscribers':
            publisher = self.publishers[name]
            count = int(command.get('count', 1))
            self.spin_until(
                lambda: publisher.get_subscription_count() >= count,
                float(command.get('timeout', 10)),
            )
            return {'count': publisher.get_subscription_count()}
        if op == 'wait_publishers':
            subscription = self.subscriptions[name]
            count = int(command.get('count', 1))
            self.spin_until(
                lambda: subscription.get_publisher_count() >= count,
                float(command.get('timeout', 10)),
            )
            return {'count': subscription.get_publisher_count()}
        if op == 'wait_readers':
            topic = command['topic']
            count = int(command.get('count', 1))
            self.spin_until(
                lambda: self.node.count_subscribers(topic) >= count,
                float(command.get('timeout', 10)),
            )
            return {'count': self.node.count_subscribers(topic)}
        if op == 'subscription':
            store: list[bytes] = []
            self.received[name] = store
            self.subscriptions[name] = self.node.create_subscription(
                _message_class(command['type']),
                command['topic'],
                lambda data: store.append(data),
                _profile(command.get('qos')),
                raw=True,
                callback_group=self.group(),
            )
            return {}
        if op == 'wait_messages':
            store = self.received[name]
            count = int(command.get('count', 1))
            self.spin_until(lambda: len(store) >= count, float(command.get('timeout', 10)))
            return {'messages': [data.hex() for data in store]}
        if op == 'topics':
            return {'topics': self.node.get_topic_names_and_types()}
        if op == 'wait_topic':
            wanted = (command['topic'], command['type'])
            present = bool(command.get('present', True))

            def seen() -> bool:
                found = any(
                    topic == wanted[0] and wanted[1] in types
                    for topic, types in self.node.get_topic_names_and_types()
                )
                return found == present

            self.spin_until(seen, float(command.get('timeout', 10)))
            return {'topics': self.node.get_topic_names_and_types()}
        if op == 'service':
            srv_class = _message_class(command['type'])

            def echo(request: Any, response: Any) -> Any:
                for field in response.get_fields_and_field_types():
                    if hasattr(request, field):
                        setattr(response, field, getattr(request, field))
                return response

            self.others[name] = self.node.create_service(
                srv_class, command['service'], echo, callback_group=self.group()
            )
            return {}
        if op == 'call':
            return self.call(command)
        if op == 'action_server':
            return self.action_server(name, command)
        if op == 'action_call':
            return self.action_call(command)
        if op in ('param_node', 'param_node_op', 'param_client', 'param_call'):
            handler: Any = getattr(self, op)
            return dict(handler(name, command))
        if op == 'param_events':
            client = self.param_clients[command['client']]
            store_events: list[dict[str, Any]] = []
            self.param_events[name] = store_events
            self.subscriptions[name] = client.on_parameter_event(
                lambda event: store_events.append(_event_json(event)), callback_group=self.group()
            )
            return {}
        if op == 'wait_param_events':
            events = self.param_events[name]
            node = command['node']
            count = int(command.get('count', 1))

            def of_node() -> list[dict[str, Any]]:
                return [event for event in list(events) if event['node'] == node]

            self.spin_until(lambda: len(of_node()) >= count, float(command.get('timeout', 10)))
            return {'events': of_node()}
        if op == 'destroy' and name in self.param_nodes:
            node = self.param_nodes.pop(name)
            self.executor.remove_node(node)
            node.destroy_node()
            return {}
        if op == 'destroy' and name in self.param_clients:
            client = self.param_clients.pop(name)
            for part in (
                client._get_parameter_client,
                client._list_parameter_client,
                client._set_parameter_client,
                client._get_parameter_types_client,
                client._describe_parameters_client,
                client._set_parameters_atomically_client,
            ):
                self.node.destroy_client(part)
            return {}
        if op == 'destroy' and name in self.param_events:
            self.param_events.pop(name)
            self.node.destroy_subscription(self.subscriptions.pop(name))
            return {}
        if op == 'destroy':
            if name in self.others:
                other = self.others.pop(name)
                # a service must leave the node's list, or its executor keeps it (and the graph
                # keeps showing it); action servers remove themselves
                if not self.node.destroy_service(other):
                    other.destroy()
            if name in self.publishers:
                self.node.destroy_publisher(self.publishers.pop(name))
            if name in self.subscriptions:
                self.node.destroy_subscription(self.subscriptions.pop(name))
                self.received.pop(name, None)
            return {}
        raise ValueError(f'unknown command {op!r}')

    # --- parameters ---------------------------------------------------------------------------

    def param_node(self, name: str, command: dict[str, Any]) -> dict[str, Any]:
        from rclpy.node import Node

        node = Node(
            command['node'],
            namespace=command.get('namespace', '/'),
            allow_undeclared_parameters=bool(command.get('allow_undeclared', False)),
        )
        try:
            self._declare(node, command.get('parameters', []))
        except BaseException:
            node.destroy_node()
            raise
        self.param_nodes[name] = node
        self.executor.add_node(node)
        return {'fqn': node.get_fully_qualified_name()}

    @staticmethod
    def _declare(node: Any, specs: list[dict[str, Any]]) -> None:
        for spec in specs:
            node.declare_parameter(
                spec['name'], _python_value(spec), _descriptor(spec.get('descriptor', {}))
            )

    def param_node_op(self, name: str, command: dict[str, Any]) -> dict[str, Any]:
        node = self.param_nodes[name]
        specs = command.get('parameters', [])
        op = command['op']
        if op == 'declare':
            self._declare(node, specs)
            return {}
        if op == 'undeclare':
            for spec in specs:
                node.undeclare_parameter(spec['name'])
            return {}
        if op == 'set':
            results = node.set_parameters([_parameter(spec) for spec in specs])
            return {'results': [_result_json(result) for result in results]}
        raise ValueError(f'unknown param_node_op {op!r}')

    def param_client(self, name: str, command: dict[str, Any]) -> dict[str, Any]:
        from rclpy.parameter_client import AsyncParameterClient

        client = AsyncParameterClient(self.node, command['node'], callback_group=self.group())
        self.param_clients[name] = client
        ready = self.spin_until(client.services_are_ready, float(command.get('timeout', 10)))
        return {'ready': ready}

    def param_call(self, name: str, command: dict[str, Any]) -> dict[str, Any]:
        client = self.param_clients[name]
        op = command['op']
        names = list(command.get('names', []))
        parameters = [_parameter(spec) for spec in command.get('parameters', [])]
        if op == 'list':
            future = client.list_parameters(command.get('prefixes'), command.get('depth'))
        elif op == 'get':
            future = client.get_parameters(names)
        elif op == 'types':
            future = client.get_parameter_types(names)
        elif op == 'describe':
            future = client.describe_parameters(names)
        elif op == 'set':
            future = client.set_parameters(parameters)
        elif op == 'set_atomically':
            future = client.set_parameters_atomically(parameters)
        elif op == 'delete':
            future = client.delete_parameters(names)
        else:
            raise ValueError(f'unknown param_call op {op!r}')
        if not self.spin_until(future.done, float(command.get('timeout', 10))):
            future.cancel()
            raise TimeoutError(f'no response to {op} from {client.remote_node_name}')
        response = future.result()
        if op == 'list':
            return {
                'names': list(response.result.names),
                'prefixes': list(response.result.prefixes),
            }
        if op == 'get':
            return {'values': [_value_json(value) for value in response.values]}
        if op == 'types':
            return {'types': [int(kind) for kind in response.types]}
        if op == 'describe':
            return {'descriptors': [_descriptor_json(item) for item in response.descriptors]}
        if op == 'set_atomically':
            return {'result': _result_json(response.result)}
        return {'results': [_result_json(result) for result in response.results]}

    def call(self, command: dict[str, Any]) -> dict[str, Any]:
        from rclpy.serialization import deserialize_message, serialize_message

        srv_class = _message_class(command['type'])
        timeout = float(command.get('timeout', 10))
        client = self.node.create_client(srv_class, command['service'], callback_group=self.group())
        try:
            if not client.wait_for_service(timeout_sec=timeout):
                raise TimeoutError(f'no server for {command["service"]}')
            request = deserialize_message(bytes.fromhex(command['data']), srv_class.Request)
            future = client.call_async(request)
            if not self.spin_until(future.done, timeout):
                raise TimeoutError(f'no response from {command["service"]}')
            return {'response': bytes(serialize_message(future.result())).hex()}
        finally:
            self.node.destroy_client(client)

    def action_server(self, name: str, command: dict[str, Any]) -> dict[str, Any]:
        from rclpy.action import ActionServer, CancelResponse
        from test_msgs.action import Fibonacci

        cancelable = bool(command.get('cancelable', False))
        abort_order = command.get('abort_order')
        hold = float(command.get('hold', 0.0))

        def execute(goal_handle: Any) -> Any:
            order = goal_handle.request.order
            sequence = [0, 1]
            for step in range(1, order):
                if cancelable and goal_handle.is_cancel_requested:
                    goal_handle.canceled()
                    return Fibonacci.Result(sequence=sequence)
                sequence.append(sequence[-1] + sequence[-2])
                goal_handle.publish_feedback(Fibonacci.Feedback(sequence=sequence))
                if abort_order is not None and order == int(abort_order):
                    goal_handle.abort()
                    return Fibonacci.Result(sequence=sequence)
                if step == 1 and cancelable and hold:
                    self.spin_until(lambda: goal_handle.is_cancel_requested, hold)
                else:
                    time.sleep(STEP)
            if cancelable and goal_handle.is_cancel_requested:
                goal_handle.canceled()
            else:
                goal_handle.succeed()
            return Fibonacci.Result(sequence=sequence)

        def cancel(_goal_handle: Any) -> Any:
            return CancelResponse.ACCEPT if cancelable else CancelResponse.REJECT

        self.others[name] = ActionServer(
            self.node,
            Fibonacci,
            command['action'],
            execute,
            cancel_callback=cancel,
            callback_group=self.group(),
        )
        return {}

    def action_call(self, command: dict[str, Any]) -> dict[str, Any]:
        from action_msgs.msg import GoalStatus, GoalStatusArray
        from rclpy.action import ActionClient
        from rclpy.qos import QoSProfile, qos_profile_action_status_default
        from test_msgs.action import Fibonacci

        timeout = float(command.get('timeout', 10))
        action = command['action']
        client = ActionClient(self.node, Fibonacci, action, callback_group=self.group())
        feedback: list[list[int]] = []
        messages: list[tuple[bytes, list[int]]] = []  # (goal id, sequence) on the feedback topic
        arrays: list[list[tuple[bytes, int]]] = []  # [(goal id, state)...] on the status topic
        subscriptions: list[Any] = []
        if command.get('record'):
            subscriptions = [
                self.node.create_subscription(
                    Fibonacci.Impl.FeedbackMessage,
                    f'{action}/_action/feedback',
                    lambda m: messages.append((bytes(m.goal_id.uuid), list(m.feedback.sequence))),
                    QoSProfile(depth=100),
                    callback_group=self.group(),
                ),
                self.node.create_subscription(
                    GoalStatusArray,
                    f'{action}/_action/status',
                    lambda m: arrays.append(
                        [(bytes(s.goal_info.goal_id.uuid), s.status) for s in m.status_list]
                    ),
                    qos_profile_action_status_default,
                    callback_group=self.group(),
                ),
            ]
        try:
            if not client.wait_for_server(timeout_sec=timeout):
                raise TimeoutError(f'no action server for {action}')
            if not self.spin_until(
                lambda: all(s.get_publisher_count() for s in subscriptions), timeout
            ):
                raise TimeoutError(f'the feedback or status topic of {action} has no publisher')
            goal = Fibonacci.Goal(order=int(command['order']))
            sent = client.send_goal_async(
                goal, feedback_callback=lambda f: feedback.append(list(f.feedback.sequence))
            )
            if not self.spin_until(sent.done, timeout):
                raise TimeoutError('send_goal got no response')
            handle = sent.result()
            if not handle.accepted:
                return {'accepted': False}
            goal_id = bytes(handle.goal_id.uuid)
            reply: dict[str, Any] = {'accepted': True, 'goal_id': goal_id.hex()}
            if command.get('cancel_after_feedback'):
                if not self.spin_until(lambda: bool(feedback), timeout):
                    raise TimeoutError('no feedback came, so the goal was not canceled')
                canceled = handle.cancel_goal_async()
                if not self.spin_until(canceled.done, timeout):
                    raise TimeoutError('cancel_goal got no response')
                response = canceled.result()
                reply['cancel'] = {
                    'return_code': response.return_code,
                    'goals_canceling': [
                        bytes(info.goal_id.uuid).hex() for info in response.goals_canceling
                    ],
                }
            result = handle.get_result_async()
            if not self.spin_until(result.done, timeout):
                raise TimeoutError('get_result got no response')
            wrapped = result.result()
            reply.update(
                status=wrapped.status,
                sequence=list(wrapped.result.sequence),
                feedback=list(feedback),
            )
            if subscriptions:
                terminal = (
                    GoalStatus.STATUS_SUCCEEDED,
                    GoalStatus.STATUS_CANCELED,
                    GoalStatus.STATUS_ABORTED,
                )

                def seen() -> tuple[list[list[int]], list[int]]:
                    return (
                        [sequence for g, sequence in list(messages) if g == goal_id],
                        [state for array in list(arrays) for g, state in array if g == goal_id],
                    )

                wanted = int(command.get('feedback_count', 0))
                self.spin_until(
                    lambda: len(seen()[0]) >= wanted and any(s in terminal for s in seen()[1]),
                    timeout,
                )
                topic_feedback, statuses = seen()
                reply.update(topic_feedback=topic_feedback, statuses=statuses)
            return reply
        finally:
            for subscription in subscriptions:
                self.node.destroy_subscription(subscription)
            client.destroy()

    def serve(self, reader: TextIO, writer: TextIO) -> None:
        writer.write(json.dumps({'ok': True, 'ready': self.node.get_name()}) + '\n')
        writer.flush()
        for line in reader:
            if not line.strip():
                continue
            command = json.loads(line)
            if command.get('cmd') == 'exit':
                break
            try:
                reply = {'ok': True, **self.handle(command)}
            except Exception as exc:
                reply = {'ok': False, 'error': f'{type(exc).__name__}: {exc}'}
            writer.write(json.dumps(reply) + '\n')
            writer.flush()

    def close(self) -> None:
        self.stopping.set()
        self.executor.shutdown()
        self.spinner.join(5)
        self.node.destroy_node()
        self.rclpy.shutdown()


def serve(address: str) -> None:
    """Accept connections forever on ``tcp:HOST:PORT`` or ``unix:PATH``; each connection gets a
    worker subprocess whose stdin and stdout are the socket."""
    scheme, _, where = address.partition(':')
    if scheme == 'unix':
        if os.path.exists(where):
            os.unlink(where)
        server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        server.bind(where)
        server.listen()
    elif scheme == 'tcp':
        host, _, port = where.rpartition(':')
        server = socket.create_server((host or '0.0.0.0', int(port)), reuse_port=True)
    else:
        raise SystemExit(f'--serve takes tcp:HOST:PORT or unix:PATH, not {address!r}')
    print(f'ros_worker serving on {address}', flush=True)
    children: list[subprocess.Popen[bytes]] = []
    while True:
        connection, _ = server.accept()
        child = subprocess.Popen(
            [sys.executable, os.path.abspath(__file__)],
            stdin=connection.fileno(),
            stdout=connection.fileno(),
        )
        connection.close()
        children.append(child)
        children = [c for c in children if c.poll() is None]


def main() -> None:
    if len(sys.argv) == 3 and sys.argv[1] == '--serve':
        serve(sys.argv[2])
        return
    worker = Worker()
    try:
        worker.serve(sys.stdin, sys.stdout)
    finally:
        worker.close()


if __name__ == '__main__':
    main()

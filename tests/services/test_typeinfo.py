"""``~/get_type_description``: a zros node describes its types, another learns them."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from zros.cdr import Message
from zros.cdr.hashing import type_hash
from zros.cdr.registry import TypeRegistry
from zros.node import Node
from zros.services import Client, typeinfo
from zros.services.typeinfo import (
    SERVICE_TYPE,
    TypeDescriptionService,
    learn_type,
    register_description,
)

READING = 'zros_test_msgs/msg/Reading'
READING_TEXT = """\
# A reading.
uint8 OK=0
uint8 status  # OK, or an error code
float64[3] values [1.0, 2.0, 3.0]
geometry_msgs/Point where
"""


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module runs on both wire schemes."""
    return str(request.param)


def own_registry() -> TypeRegistry:
    return TypeRegistry('jazzy', paths=[], ament=False)


def test_a_node_learns_a_type_another_node_serves(zros_node: Callable[..., Node]) -> None:
    served = own_registry()
    served.register_text(READING, READING_TEXT)
    server = TypeDescriptionService(zros_node('player'))
    server.add(served.get_class(READING))
    learner = zros_node('cli', registry=own_registry())
    assert learner.registry.find(READING) is None
    expected = type_hash(served, READING)
    assert learn_type(learner, READING, [('/player', expected)]) == '/player'
    learned = learner.registry.definition(READING)
    assert learned == served.definition(READING)  # constants and defaults too, from the text
    assert learned.source == READING_TEXT  # comments as well
    assert type_hash(learner.registry, READING) == expected
    # a wrong hash, an unknown type, a node that serves nothing: no answer, nothing registered
    other = zros_node('other', registry=own_registry())
    assert learn_type(other, READING, [('/player', 'RIHS01_' + '0' * 64)]) is None
    assert learn_type(other, 'zros_test_msgs/msg/Nope', [('/player', None)]) is None
    assert learn_type(other, READING, [('/nobody', None)], timeout=0.5) is None
    assert other.registry.find(READING) is None
    server.close()


def test_without_sources_the_description_gives_the_structure(
    zros_node: Callable[..., Node],
) -> None:
    # as rclpy answers: fields, nested types and defaults, no text (so no constants)
    served = own_registry()
    served.register_text(READING, READING_TEXT)
    server = TypeDescriptionService(zros_node('player'))
    server.add(served.get_class(READING))
    learner = zros_node('cli', registry=own_registry())
    client = learner.create_client(SERVICE_TYPE, '/player/get_type_description')
    assert client.wait_for_service(10)
    response = client.call(type_name=READING, type_hash='', include_type_sources=False)
    assert response.successful and not response.type_sources
    register_description(learner.registry, response, 'test')
    learned = learner.registry.definition(READING)
    assert [f.name for f in learned.fields] == ['status', 'values', 'where']
    assert learned.fields[1].default == (1.0, 2.0, 3.0)
    assert type_hash(learner.registry, READING) == type_hash(served, READING)
    server.close()


STATUS = 'my_robot_msgs/msg/Status'
STATUS_TEXT = 'string mode\nfloat64 battery\nint32[] errors\n'


def serves_types(node: Node) -> bool:
    """Whether ``node`` has a ``~/get_type_description`` service among its entities."""
    return any(getattr(e, 'type_name', '') == SERVICE_TYPE for e in node.context.entities)


def describe(client: Client, name: str, type_hash: str = '') -> Message:
    return client.call(type_name=name, type_hash=type_hash, include_type_sources=True)


def status_publisher(make: Callable[..., Node], **options: object) -> tuple[Node, TypeRegistry]:
    """A node ``custom_pub`` publishing ``/status`` of STATUS, registered at run time in its
    registry (the user's report)."""
    registry = own_registry()
    registry.register_text(STATUS, STATUS_TEXT)
    node = make('custom_pub', registry=registry, **options)
    node.create_publisher(STATUS, '/status', 10)
    return node, registry


def test_a_node_serves_its_types_once_it_uses_a_custom_one(
    zros_node: Callable[..., Node],
) -> None:
    registry = own_registry()
    registry.register_text(STATUS, STATUS_TEXT)
    node = zros_node('custom_pub', registry=registry)
    node.create_subscription('std_msgs/msg/String', '/chatter')
    assert not serves_types(node)  # standard types only: nothing added to the graph
    node.create_publisher(STATUS, '/status', 10)
    assert serves_types(node)
    learner = zros_node('cli', registry=own_registry())
    expected = type_hash(registry, STATUS)
    assert learn_type(learner, STATUS, [('/custom_pub', expected)]) == '/custom_pub'
    learned = learner.registry.definition(STATUS)
    assert [f.name for f in learned.fields] == ['mode', 'battery', 'errors']
    assert learned.source == STATUS_TEXT
    client = learner.create_client(SERVICE_TYPE, '/custom_pub/get_type_description')
    assert client.wait_for_service(10)
    # a standard type the node uses is described too (as rclpy does); one it does not use is not
    string = describe(client, 'std_msgs/msg/String')
    assert string.successful
    assert string.type_description.type_description.type_name == 'std_msgs/msg/String'
    pose = describe(client, 'geometry_msgs/msg/Pose')
    assert not pose.successful
    assert pose.failure_reason == "'geometry_msgs/msg/Pose' is not a type of this node"


def test_hostile_requests_get_a_failure_and_the_node_keeps_answering(
    zros_node: Callable[..., Node],
) -> None:
    _, registry = status_publisher(zros_node)
    client = zros_node('cli').create_client(SERVICE_TYPE, '/custom_pub/get_type_description')
    assert client.wait_for_service(10)
    unknown = describe(client, 'my_robot_msgs/msg/Nope')
    assert not unknown.successful
    assert unknown.failure_reason == "'my_robot_msgs/msg/Nope' is not a type of this node"
    wrong = describe(client, STATUS, 'RIHS01_' + '0' * 64)
    assert not wrong.successful
    assert wrong.failure_reason.startswith(f'{STATUS} has the hash RIHS01_')
    huge = describe(client, 'x' * 1_000_000)
    assert not huge.successful
    assert huge.failure_reason.endswith('... (1000000 chars) is not a type of this node')
    assert len(huge.failure_reason) < 200  # not echoed back whole
    for bad in ['', '/', 'not a name', 'pkg/msg/', 'pkg/weird/Kind']:
        answer = describe(client, bad)
        assert not answer.successful and answer.failure_reason
    assert describe(client, STATUS, type_hash(registry, STATUS)).successful


def test_start_type_description_service_false_serves_nothing(
    zros_node: Callable[..., Node],
) -> None:
    node, _ = status_publisher(zros_node, start_type_description_service=False)
    assert not serves_types(node)
    learner = zros_node('cli', registry=own_registry())
    assert learn_type(learner, STATUS, [('/custom_pub', None)], timeout=0.5) is None


def test_a_description_that_fails_is_answered_not_raised(
    zros_node: Callable[..., Node], monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken(registry: TypeRegistry, name: str) -> None:
        raise RuntimeError('no description')

    monkeypatch.setattr(typeinfo, 'type_description', broken)
    status_publisher(zros_node)
    client = zros_node('cli').create_client(SERVICE_TYPE, '/custom_pub/get_type_description')
    assert client.wait_for_service(10)
    answer = describe(client, STATUS)
    assert not answer.successful
    assert answer.failure_reason == f"'{STATUS}' failed: no description"


def test_a_player_style_service_refuses_malformed_names(zros_node: Callable[..., Node]) -> None:
    # everything=True (a bag player's) looks names up in the node's registry
    server = TypeDescriptionService(zros_node('player'))
    client = zros_node('cli').create_client(SERVICE_TYPE, '/player/get_type_description')
    assert client.wait_for_service(10)
    for bad in ['', '/', 'not a name', 'pkg/msg/', 'pkg/weird/Kind', 'x' * 5000]:
        answer = describe(client, bad)
        assert not answer.successful and 'is not a type of this node' in answer.failure_reason
    assert describe(client, 'std_msgs/msg/String').successful
    server.close()


def test_services_and_actions_of_custom_types_are_described(
    zros_node: Callable[..., Node],
) -> None:
    registry = own_registry()
    registry.register_text('my_robot_msgs/srv/Reset', 'bool hard\n---\nbool ok\n')
    registry.register_text(
        'my_robot_msgs/action/Dock', 'int32 bay\n---\nbool ok\n---\nfloat32 left\n'
    )
    node = zros_node('robot', registry=registry)
    node.create_service('my_robot_msgs/srv/Reset', '/reset', lambda request: None)
    node.create_action_server('my_robot_msgs/action/Dock', '/dock', lambda handle: None)
    client = zros_node('cli').create_client(SERVICE_TYPE, '/robot/get_type_description')
    assert client.wait_for_service(10)
    for name in ['my_robot_msgs/srv/Reset', 'my_robot_msgs/action/Dock']:
        answer = describe(client, name, type_hash(registry, name))
        assert answer.successful, answer.failure_reason
        assert answer.type_description.type_description.type_name == name

"""``~/get_type_description``: a zros node describes its types, another learns them."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from zros.cdr.hashing import type_hash
from zros.cdr.registry import TypeRegistry
from zros.node import Node
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

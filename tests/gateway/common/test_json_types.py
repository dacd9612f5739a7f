"""Reading fields of a client's JSON object with their types checked."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from zros.gateway.common.errors import GatewayError
from zros.gateway.common.json_types import JsonObject, int_field, optional_text, text_field


def test_fields_are_read_with_their_type() -> None:
    op: JsonObject = {'topic': '/a', 'queue_length': 3, 'type': None}
    assert text_field(op, 'topic') == '/a'
    assert text_field(op, 'missing', '') == ''
    assert optional_text(op, 'type') is None and optional_text(op, 'missing') is None
    assert int_field(op, 'queue_length') == 3 and int_field(op, 'missing', 7) == 7


@pytest.mark.parametrize(
    ('read', 'text'),
    [
        (lambda op: text_field(op, 'number'), 'the field number must be a string, not 5'),
        (lambda op: text_field(op, 'missing'), 'the field missing must be a string, not None'),
        (lambda op: optional_text(op, 'number'), 'must be a string'),
        (lambda op: int_field(op, 'topic'), "the field topic must be an integer, not '/a'"),
        (lambda op: int_field(op, 'flag'), 'the field flag must be an integer, not True'),
    ],
)
def test_a_field_of_another_type_is_refused(
    read: Callable[[JsonObject], object], text: str
) -> None:
    op: JsonObject = {'topic': '/a', 'number': 5, 'flag': True}
    with pytest.raises(GatewayError, match=text):
        read(op)

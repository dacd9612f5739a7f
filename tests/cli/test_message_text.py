"""Byte fields as ``zros topic echo`` prints them, and what it says of a value that is no byte."""

from __future__ import annotations

import numpy as np
import pytest

import zros
from zros import cdr
from zros.cli.message_text import to_plain

zros.register_type('zros_text_test_msgs/msg/Bytes', 'byte b\nbyte[] bs\nbyte[2] fixed')


def _message(**fields: object) -> cdr.Message:
    return cdr.new_message('zros_text_test_msgs/msg/Bytes', **fields)


def test_bytes_print_as_characters_and_in_csv_as_python_bytes() -> None:
    sent = _message(b=65, bs=b'AB', fixed=[66, 255])
    received = cdr.decode('zros_text_test_msgs/msg/Bytes', cdr.encode(sent))
    for message in (sent, received):
        assert to_plain(message) == {'b': 'A', 'bs': ['A', 'B'], 'fixed': ['B', '\xff']}
        assert to_plain(message, csv=True) == {
            'b': "b'A'",
            'bs': ["b'A'", "b'B'"],
            'fixed': ["b'B'", "b'\\xff'"],
        }


def test_a_byte_held_as_a_numpy_integer_or_as_bytes_prints_the_same() -> None:
    assert to_plain(_message(b=np.uint8(67)))['b'] == 'C'
    message = _message()
    message.b = b'D'  # as rclpy holds a byte
    assert to_plain(message)['b'] == 'D'


def test_a_value_that_is_no_byte_is_named() -> None:
    message = _message()
    message.b = 1.5
    with pytest.raises(TypeError, match='a byte field holds float'):
        to_plain(message)

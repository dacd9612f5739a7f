"""Sizes on the command line (``--client-buffer`` of both gateways)."""

from __future__ import annotations

import argparse

import pytest

from zros.cli.arg_types import byte_count


@pytest.mark.parametrize(
    ('text', 'size'),
    [
        ('33554432', 32 * 1024**2),
        ('32MiB', 32 * 1024**2),
        ('500kB', 500_000),
        ('1.5 GiB', 3 * 1024**3 // 2),
        ('2M', 2_000_000),
    ],
)
def test_sizes_read_with_their_units(text: str, size: int) -> None:
    assert byte_count(text) == size


@pytest.mark.parametrize('text', ['x', '0', '-5', 'MiB', '12 parsecs', ''])
def test_a_bad_size_names_the_forms_it_takes(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError, match=r'as 33554432, 32MiB or 500kB'):
        byte_count(text)

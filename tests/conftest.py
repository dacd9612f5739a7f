"""Shared test configuration."""

from __future__ import annotations

from pathlib import Path

import pytest

#: Real recordings live beside the repository, never inside it.
TESTDATA = Path(__file__).resolve().parent.parent.parent / 'shared' / 'testdata'


@pytest.fixture
def testdata() -> Path:
    """The shared recordings folder; tests using it skip where it is absent."""
    if not TESTDATA.is_dir():
        pytest.skip(f'recordings folder {TESTDATA} is absent (it is not part of a clone)')
    return TESTDATA

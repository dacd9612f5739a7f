"""Recording and playing under rmw_zenoh's key scheme: every recorder and player test of the
bridge scheme, run again with nodes speaking rmw_zenoh (keys with type and hash, attachments)."""

from __future__ import annotations

import pytest

from tests.bag.play.test_play import *  # noqa: F403
from tests.bag.write.test_record import *  # noqa: F403


@pytest.fixture
def zros_wire() -> str:
    """The nodes of these tests speak rmw_zenoh."""
    return 'rmw_zenoh'

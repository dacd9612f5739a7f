"""zros.closing: the one ``with`` of zros objects."""

from __future__ import annotations

import pytest

from zros.closing import Closing


class Door(Closing):
    def __init__(self) -> None:
        self.closed = 0

    def close(self) -> None:
        self.closed += 1


def test_a_with_block_closes_it_however_it_ends() -> None:
    with Door() as door:
        assert isinstance(door, Door) and door.closed == 0
    assert door.closed == 1
    with pytest.raises(ValueError, match='inside'), Door() as door:
        raise ValueError('inside')
    assert door.closed == 1


def test_a_class_without_its_own_close_says_so() -> None:
    with pytest.raises(NotImplementedError), Closing():
        pass


def test_the_with_objects_of_zros_close_through_closing() -> None:
    from zros.bag import Bag, BagWriter, Player, Recorder
    from zros.bag.read.source_base import Source
    from zros.gateway.foxglove.bag_server import BagGateway
    from zros.gateway.foxglove.server import FoxgloveGateway
    from zros.gateway.rosbridge.server import RosbridgeGateway
    from zros.node import Node
    from zros.transport import Router, Transport

    for cls in (Node, Transport, Router, Bag, Source, BagWriter, Recorder, Player):
        assert issubclass(cls, Closing), cls
    for cls in (BagGateway, FoxgloveGateway, RosbridgeGateway):
        assert issubclass(cls, Closing), cls
        assert '__exit__' not in vars(cls), cls

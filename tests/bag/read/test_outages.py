"""A recording's link outages (``zros bag record``'s gaps) read back from the bag."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from zros.bag import Bag, LinkOutage, info
from zros.bag.read.outages import OUTAGES_KEY, outages_text
from zros.bag.write.bag_writer import BagTopic, BagWriter
from zros.cdr import default_registry, encode, new_message

STRING = 'std_msgs/msg/String'
SECOND = 1_000_000_000
START = 1_764_000_000 * SECOND  # in 2025


def recording(folder: Path, custom: dict[str, str]) -> Path:
    """A bag of three messages a second apart, with ``custom`` as its custom data."""
    with BagWriter(folder, ros_distro='jazzy') as bag:
        index = bag.add_topic(BagTopic.from_registry(default_registry(), '/chatter', STRING))
        for second in range(3):
            bag.write(index, START + second * SECOND, encode(new_message(STRING, data='hi')))
        bag.custom_data.update(custom)  # as the recorder does at its close
    return folder


def test_outages_read_back_from_the_folder_and_from_its_file(tmp_path: Path) -> None:
    """An analyst who finds a gap in a recording can tell the link's loss from a quiet robot,
    from the folder and from its MCAP file alone (copied out of the folder)."""
    outages = [
        LinkOutage(START + 2 * SECOND // 10, START + 15 * SECOND // 10),
        LinkOutage(START + SECOND // 10, START + SECOND // 10 + 5),
    ]
    folder = recording(tmp_path / 'gap', {OUTAGES_KEY: outages_text(outages), 'robot': 'r2'})
    expected = sorted(outages, key=lambda o: o.start_ns)
    with Bag(folder) as bag:
        assert bag.outages == expected
        assert bag.custom_data['robot'] == 'r2'
    with Bag(folder / 'gap_0.mcap') as bag:
        assert bag.outages == expected
    assert expected[1].duration_ns == 13 * SECOND // 10
    text = str(info(folder))
    assert 'Link outages:      2, 1.3 s in all: messages published then are missing\n' in text
    assert ' for 0.000 s\n' in text and ' for 1.300 s\n' in text


def test_a_recording_without_outages_shows_none(tmp_path: Path) -> None:
    folder = recording(tmp_path / 'whole', {})
    with Bag(folder) as bag:
        assert bag.outages == [] and bag.custom_data == {}
    assert 'Link outages' not in str(info(folder))


@pytest.mark.parametrize('value', ['not json', '[[1]]', '{"a": 1}', '[["x", 2]]', '3'])
def test_outages_that_do_not_read_are_ignored_with_a_warning(
    tmp_path: Path, value: str, caplog: pytest.LogCaptureFixture
) -> None:
    """A hand-edited or foreign value costs only the outages: the bag still reads."""
    folder = recording(tmp_path / 'edited', {OUTAGES_KEY: value})
    with caplog.at_level(logging.WARNING, 'zros.bag'), Bag(folder) as bag:
        assert bag.outages == []
        assert bag.message_count == 3
    assert f'{folder}: its {OUTAGES_KEY} does not read' in caplog.text

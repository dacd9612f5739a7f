"""``zros.bag.read.info`` and ``zros bag info``: the layout of ``ros2 bag info``.

The golden files were written by hand from rosbag2's own expectation for cdr_test
(rosbag2_tests/test_rosbag2_info_end_to_end.cpp: duration, start, end, counts, topic lines),
the layout of rosbag2_py's format_bag_metadata.cpp, the files' sizes and ``date -u``; a test
below checks their numbers against what rosbags reports.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from zros.bag.read.info import format_size, format_time, info

GOLDEN = Path(__file__).parent / 'golden'
CASES = {
    'cdr_test_mcap.txt': 'ros2/cdr_test_mcap',
    'topics_and_services_mcap.txt': 'ros2/services_and_topics/topics_and_services.mcap',
}


@pytest.fixture
def utc(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """ros2 bag info prints local time: pin the zone."""
    monkeypatch.setenv('TZ', 'UTC')
    time.tzset()
    yield
    monkeypatch.undo()
    time.tzset()


@pytest.mark.parametrize('golden', sorted(CASES))
def test_info_matches_the_golden_text(testdata: Path, utc: None, golden: str) -> None:
    expected = (GOLDEN / golden).read_text(encoding='utf-8')
    assert str(info(testdata / CASES[golden])) == expected.removesuffix('\n')


@pytest.mark.parametrize('golden', sorted(CASES))
def test_golden_numbers_are_what_rosbags_reports(testdata: Path, golden: str) -> None:
    from rosbags.rosbag2 import Reader

    text = (GOLDEN / golden).read_text(encoding='utf-8')
    path = testdata / CASES[golden]
    with Reader(path if path.is_file() else next(path.glob('*.mcap'))) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        start, end = reader.start_time, reader.end_time - 1
    lines = dict(re.findall(r'^(\w[\w ]*):\s+(.*)$', text, re.MULTILINE))
    assert lines['Start'].endswith(f'({start // 10**9}.{start % 10**9:09d})')
    assert lines['End'].endswith(f'({end // 10**9}.{end % 10**9:09d})')
    assert lines['Duration'] == f'{(end - start) // 10**9}.{(end - start) % 10**9:09d}s'
    topics = dict(re.findall(r'Topic: (\S+) \| Type: \S+ \| Count: (\d+)', text))
    services = dict(re.findall(r'Service: (\S+) \| Type: \S+ \| Event Count: (\d+)', text))
    shown = {t: int(n) for t, n in topics.items()}
    shown |= {f'{s}/_service_event': int(n) for s, n in services.items()}
    assert shown == counts
    assert int(lines['Messages']) == sum(int(n) for n in topics.values())
    size = sum(f.stat().st_size for f in (path.iterdir() if path.is_dir() else [path]))
    assert lines['Bag size'] == format_size(size)


def test_sizes_and_times() -> None:
    assert [format_size(n) for n in (0, 1023, 1024, 1536, 5 * 2**20, 3 * 2**40, 2**52)] == [
        '0 B',
        '1023 B',
        '1.0 KiB',
        '1.5 KiB',
        '5.0 MiB',
        '3.0 TiB',
        '4096.0 TiB',
    ]
    local = time.localtime(86400 * 40)
    assert format_time(86400 * 40 * 10**9 + 5).endswith(f'.000000005 ({86400 * 40}.000000005)')
    assert format_time(86400 * 40 * 10**9).startswith(time.strftime('%b', local))


def test_sorting_and_every_recording(testdata: Path) -> None:
    facts = info(testdata / 'ros2' / 'talker_mcap')
    by_count = facts.format('count')
    assert by_count.index('/parameter_events') < by_count.index('/rosout')
    by_type = facts.format('type')
    assert by_type.index('rcl_interfaces/msg/Log') < by_type.index('std_msgs/msg/String')
    with pytest.raises(ValueError, match='sort by one of'):
        facts.format('size')
    split = info(testdata / 'ros2' / 'wbag_split_mcap')
    assert split.files == [f'wbag_{i}.mcap' for i in range(5)]
    assert split.message_count == 6074
    ros1 = info(testdata / 'ros1' / 'fake_sensors_sample.bag')
    assert ros1.storage_id == 'rosbag1'
    # recorded as ROS 1 serialization, whatever zros converts it to on reading
    assert {t.serialization for t in ros1.topics} == {'ros1'}
    assert str(ros1).count('Serialization Format: ros1') == 2
    for name in ('tf_example_db3', 'tf_nav2_mcap'):
        assert {t.serialization for t in info(testdata / 'ros2' / name).topics} == {'cdr'}
    assert {t.name: t.count for t in ros1.topics} == {
        '/my_magnetic_field': 10,
        '/my_temperature': 10,
    }
    empty = str(info(testdata / 'ros2' / 'empty_bag'))
    assert 'Messages:          0' in empty and 'Duration:          0.000000000s' in empty


ZROS = shutil.which('zros', path=str(Path(sys.executable).parent))


def _zros(*args: str) -> subprocess.CompletedProcess[str]:
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    env = {**os.environ, 'TZ': 'UTC'}
    return subprocess.run(
        [ZROS, *args], capture_output=True, text=True, timeout=120, check=False, env=env
    )


def test_console_script(testdata: Path, tmp_path: Path) -> None:
    result = _zros('bag', 'info', str(testdata / 'ros2' / 'cdr_test_mcap'))
    assert result.returncode == 0, result.stderr
    assert result.stdout == (GOLDEN / 'cdr_test_mcap.txt').read_text(encoding='utf-8') + '\n'
    missing = _zros('bag', 'info', str(tmp_path / 'nothing'))
    assert missing.returncode == 1
    assert missing.stderr == f'zros: error: {tmp_path / "nothing"}: no such file or folder\n'
    (tmp_path / 'junk.mcap').write_bytes(b'junk')
    junk = _zros('bag', 'info', str(tmp_path / 'junk.mcap'))
    assert junk.returncode == 1
    assert 'junk.mcap: cannot open the recording' in junk.stderr
    assert _zros('bag', 'info').returncode == 2

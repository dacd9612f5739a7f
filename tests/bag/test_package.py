"""The package ``zros.bag``: reading needs no Zenoh, every public name is where docs say."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import zros.bag
from tests.bag.makebags import make_db3, make_points_mcap
from zros.cdr import encode, new_message

ROOT = Path(__file__).resolve().parents[2]


def test_reading_a_bag_loads_no_zenoh(tmp_path: Path) -> None:
    path = make_points_mcap(tmp_path / 'points.mcap', 50)
    strings = [(0, n, encode(new_message('std_msgs/msg/String', data=f's{n}'))) for n in range(3)]
    db3 = make_db3(tmp_path / 'strings.db3', [('/chatter', 'std_msgs/msg/String')], strings)
    script = textwrap.dedent(
        f"""
        import sys
        import zros.bag
        with zros.bag.Bag({str(path)!r}) as bag:
            assert len(list(bag.messages())) == 50
            assert len(bag.columns('/point', ['x'])['x']) == 50
        assert len(zros.bag.bag_read({str(path)!r}).message) == 50
        with zros.bag.Bag({str(db3)!r}) as bag:
            assert [m.data for _, _, m in bag.messages()] == ['s0', 's1', 's2']
        print(zros.bag.info({str(path)!r}).message_count)
        loaded = sorted(m for m in sys.modules if m.split('.')[0] == 'zenoh')
        print(loaded or 'no zenoh')
        """
    )
    done = subprocess.run(
        [sys.executable, '-c', script],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split('\n')[:2] == ['50', 'no zenoh']


@pytest.mark.parametrize('name', zros.bag.__all__)
def test_every_public_name_is_importable_from_the_package(name: str) -> None:
    value = getattr(zros.bag, name)
    assert getattr(value, '__name__', name) == name
    assert name in dir(zros.bag)


def test_an_unknown_name_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match=r"'zros\.bag' has no attribute 'Recordr'"):
        zros.bag.Recordr  # noqa: B018 (the access is the test)
    with pytest.raises(ImportError):
        from zros.bag import Recordr  # type: ignore[attr-defined]  # noqa: F401

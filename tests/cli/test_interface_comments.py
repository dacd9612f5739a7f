"""``zros interface show`` prints comments from ``.msg`` sources and says where they came from
(or that none was found). The sources are small files written here, in our own words."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from zros.cdr.registry import TypeRegistry, default_registry, set_default_registry
from zros.cli.main import main

NO_SOURCES = '(no comments: no .msg sources found; set ZROS_INTERFACE_PATH)\n'
# tf2_msgs is in the rosbags typestore but not among the ROS 2 wheels this environment may have
TYPE = 'tf2_msgs/msg/TFMessage'
TOP = '# every transform known at one instant, in our words\n'
TOP_TEXT = TOP + 'geometry_msgs/TransformStamped[] transforms\n'
NESTED_TEXT = (
    '# one frame placed in another (our note)\n'
    'std_msgs/Header header\nstring child_frame_id\nTransform transform\n'
)

Show = Callable[..., tuple[str, str]]


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


@pytest.fixture
def show(capsys: pytest.CaptureFixture[str]) -> Iterator[Show]:
    """Runs ``zros interface show`` with a registry built from the given sources."""
    previous = default_registry()

    def run(*flags: str, paths: list[Path], ament: bool = True) -> tuple[str, str]:
        set_default_registry(TypeRegistry(paths=paths, ament=ament))
        assert main(['interface', 'show', TYPE, *flags]) == 0
        captured = capsys.readouterr()
        return captured.out, captured.err

    yield run
    set_default_registry(previous)


def test_comments_from_zros_interface_path(show: Show, tmp_path: Path) -> None:
    source = write(tmp_path / 'tf2_msgs' / 'msg' / 'TFMessage.msg', TOP_TEXT)
    write(tmp_path / 'geometry_msgs' / 'msg' / 'TransformStamped.msg', NESTED_TEXT)
    out, err = show(paths=[tmp_path], ament=False)
    assert out.startswith(TOP + 'geometry_msgs/TransformStamped[] transforms\n')
    assert 'our note' not in out  # nested comments only with --all-comments
    assert err == f'(comments from {source})\n'  # said once
    out, err = show('--all-comments', paths=[tmp_path], ament=False)
    assert out.startswith(TOP) and '\t# one frame placed in another (our note)\n' in out
    out, err = show('--no-comments', paths=[tmp_path], ament=False)
    assert out.startswith('geometry_msgs/TransformStamped[] transforms\n')
    assert '#' not in out and err == ''


def test_comments_from_an_ament_prefix(
    show: Show, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    source = write(tmp_path / 'share' / 'tf2_msgs' / 'msg' / 'TFMessage.msg', TOP_TEXT)
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path))
    out, err = show(paths=[])
    assert out.startswith(TOP) and err == f'(comments from {source})\n'


def test_comments_from_a_workspace_install(show: Show, tmp_path: Path) -> None:
    install = tmp_path / 'ws' / 'install'
    source = write(install / 'tf2_msgs' / 'share' / 'tf2_msgs' / 'msg' / 'TFMessage.msg', TOP_TEXT)
    out, err = show(paths=[install], ament=False)
    assert out.startswith(TOP) and err == f'(comments from {source})\n'


def test_no_sources_says_how_to_get_comments(show: Show) -> None:
    out, err = show(paths=[], ament=False)
    assert out.startswith('geometry_msgs/TransformStamped[] transforms\n')
    assert err == NO_SOURCES
    assert show('--no-comments', paths=[], ament=False)[1] == ''

"""``zros bag play`` run as a user runs it."""

from __future__ import annotations

import statistics
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests.bag.play.test_play import MS, START, Listener, gap_errors_ms, irregular, write_bag
from tests.bag.write.test_record_cli import zros_cli  # noqa: F401 (the fixture)
from tests.cli.conftest import Cli
from zros.cli.verbs.bag import _on_key
from zros.testing import wait_for

Node = Callable[..., Any]


def test_play_with_rate_and_remap(zros_cli: Cli, zros_node: Node, tmp_path: Path) -> None:  # noqa: F811
    messages = irregular(40, ['/cli/chat'], seed=3)
    bag = write_bag(tmp_path / 'bag', messages)
    listener = Listener(zros_node('listener'), '/cli/talk')
    result = zros_cli.run(
        'bag', 'play', str(bag), '--rate', '2', '--remap', '/cli/chat:=/cli/talk',
        '--wait-for-subscribers', '10',
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith(f'Playing {bag}: 40 messages on 1 topic, ')
    assert lines[-1] == 'Played 40 messages'
    assert result.stderr == ''  # no progress line: stderr is not a terminal
    assert wait_for(lambda: len(listener.got) == 40)
    assert listener.texts() == [text for _, _, text in messages]
    assert statistics.median(gap_errors_ms(listener, messages, 2.0)) < 5.0


def test_one_message_is_counted_as_one(zros_cli: Cli, tmp_path: Path) -> None:  # noqa: F811
    bag = write_bag(tmp_path / 'bag', irregular(1, ['/cli/once'], seed=1))
    result = zros_cli.run('bag', 'play', str(bag))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith(f'Playing {bag}: 1 message on 1 topic, ')
    assert lines[-1] == 'Played 1 message'


def test_play_selected_topics_in_a_loop_until_interrupted(
    zros_cli: Cli,  # noqa: F811
    zros_node: Node,
    tmp_path: Path,
) -> None:
    import signal

    messages = [(t, START + n * 10 * MS, f'{t}{n}') for n in range(3) for t in ('/l/a', '/l/b')]
    messages.sort(key=lambda m: m[1])
    bag = write_bag(tmp_path / 'bag', messages)
    listener = Listener(zros_node('listener'), '/l/*')
    running = zros_cli.start(
        'bag', 'play', str(bag), '--loop', '--topics', '/l/b', '--wait-for-subscribers', '10'
    )
    running.wait_line(lambda line: line.startswith('Playing'))
    assert wait_for(lambda: len(listener.got) >= 9, 20)
    running.process.send_signal(signal.SIGINT)
    code, rest = running.finish()
    assert code == 0
    assert rest.startswith('Played ')
    assert {key for _, key, _ in listener.got} == {'l/b'}
    assert listener.texts()[:9] == ['/l/b0', '/l/b1', '/l/b2'] * 3


def test_play_refusals(zros_cli: Cli, tmp_path: Path) -> None:  # noqa: F811
    result = zros_cli.run('bag', 'play', str(tmp_path / 'missing'))
    assert result.returncode == 1
    assert result.stderr.startswith('zros: error:')
    bag = write_bag(tmp_path / 'bag', [('/a', START, 'x')])
    result = zros_cli.run('bag', 'play', str(bag), '--topics', '/b')
    assert result.returncode == 1
    assert 'has no topic /b' in result.stderr
    assert zros_cli.run('bag', 'play', str(bag), '--rate', '0').returncode == 2


def test_keys_steer_the_player() -> None:
    class Fake:
        def __init__(self) -> None:
            self.rate = 1.0
            self.calls: list[str] = []

        def toggle_pause(self) -> None:
            self.calls.append('pause')

        def step(self) -> None:
            self.calls.append('step')

        def set_rate(self, rate: float) -> None:
            self.rate = rate

    fake = Fake()
    assert all(_on_key(fake, key) for key in (' ', 'right', 's', 'up', 'x'))
    assert fake.calls == ['pause', 'step', 'step']
    assert abs(fake.rate - 1.1) < 1e-9
    _on_key(fake, 'down')
    assert abs(fake.rate - 1.0) < 1e-9
    assert not _on_key(fake, 'q')


def test_a_type_defined_nowhere_does_not_stop_info_or_play(
    zros_cli: Cli,  # noqa: F811
    zros_node: Node,
    tmp_path: Path,
) -> None:
    from tests.bag.test_reader import SECRET, secret_bag

    bag, _ = secret_bag(tmp_path / 'secret')
    info = zros_cli.run('bag', 'info', str(bag))
    assert info.returncode == 0, info.stderr
    assert f'Topic: /secret | Type: {SECRET} | Count: 3' in info.stdout
    listener = Listener(zros_node('listener'), '/chatter')
    result = zros_cli.run(
        'bag', 'play', str(bag), '--topics', '/chatter', '/secret', '--wait-for-subscribers', '10'
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[0].startswith(f'Playing {bag}: 3 messages on 1 topic')
    assert result.stdout.splitlines()[-1] == 'Played 3 messages'
    assert f'cannot play /secret: the bag has no definition of {SECRET}' in result.stderr
    assert 'ZROS_INTERFACE_PATH=' in result.stderr and 'playing the other topics' in result.stderr
    assert wait_for(lambda: len(listener.got) == 3)
    assert listener.texts() == ['c0', 'c1', 'c2']

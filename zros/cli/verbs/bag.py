"""``zros bag``: info, reindex, record and play (as ``ros2 bag info``, ``reindex``, ``record``
and ``play``).

``record`` runs until Ctrl-C or SIGTERM, then finishes the bag (last chunk, summary,
metadata.yaml); a SIGKILL leaves files readable up to their last chunk (written at least every
second) and a current metadata.yaml, and ``zros bag reindex`` finishes them. ``play`` plays
with the recorded timing; on a terminal, space pauses and resumes, the right arrow (or ``s``)
publishes the next message while paused, up and down change the rate by 10 %, ``q`` quits. A
status line shows on stderr when it is a terminal.
"""

from __future__ import annotations

import argparse
import datetime
import threading
from typing import TYPE_CHECKING

from zros.cli.shared import CommandError, add_connection_options, add_verbs, counted, open_node, out
from zros.cli.signals import stop_on_signals

if TYPE_CHECKING:  # the command imports the bag package only when it runs (start-up)
    from zros.bag.play.player import Player


# --- info and reindex ------------------------------------------------------------------------


def info(args: argparse.Namespace) -> int:
    from zros.bag.read.info import info as read_info

    out(read_info(args.path).format(args.sort))
    return 0


def reindex(args: argparse.Namespace) -> int:
    from zros.bag.write.reindexer import reindex as reindex_bag

    report = reindex_bag(args.path, backup=not args.no_backup)
    out(str(report))
    return 1 if report.refused else 0


def default_bag_name() -> str:
    """``rosbag2_YYYY_MM_DD-HH_MM_SS``, the folder name ``ros2 bag record`` picks."""
    return datetime.datetime.now().strftime('rosbag2_%Y_%m_%d-%H_%M_%S')


# --- record ------------------------------------------------------------------------------------


def record(args: argparse.Namespace) -> int:
    from zros.bag.progress import Progress
    from zros.bag.read.info import format_size
    from zros.bag.write.recorder import Recorder

    if not (args.all or args.topics or args.regex):
        raise CommandError('nothing to record: give topic names, -a (all) or -e REGEX')
    path = args.output or default_bag_name()
    stop = threading.Event()
    progress = Progress()
    with stop_on_signals(stop), open_node(args) as node:

        def subscribed(name: str, type_name: str) -> None:
            progress.close()
            out(f'Subscribed to topic {name} [{type_name}]')

        recorder = Recorder(
            node,
            path,
            args.topics,
            args.regex,
            args.all,
            split_size=args.max_bag_size or None,
            split_duration=args.max_bag_duration or None,
            compression=None if args.compression == 'none' else args.compression,
            include_hidden=args.include_hidden_topics,
            on_topic=subscribed,
        )
        out(f'Recording to {recorder.path}')
        transport = node.transport
        outages, downtime = transport.outages, transport.downtime
        try:
            while not stop.wait(0.1) and recorder.error is None:
                progress.update(
                    f'[RECORDING] {counted(recorder.message_count, "message")}, '
                    f'{format_size(recorder.size)}, {counted(len(recorder.files), "file")}'
                    + (f', {recorder.dropped} dropped' if recorder.dropped else '')
                )
        finally:
            progress.close()
            recorder.close()
        out(
            f'Recorded {counted(recorder.message_count, "message")} on '
            f'{counted(len(recorder.topics), "topic")} '
            f'into {counted(len(recorder.files), "file")} of {recorder.path}'
            + (f'; {recorder.dropped} dropped: writing fell behind' if recorder.dropped else '')
            + _outages(transport.outages - outages, transport.downtime - downtime)
        )
    return 0


def _outages(count: int, seconds: float) -> str:
    """The summary's note of the link outages while recording (nothing without one)."""
    if not count:
        return ''
    return (
        f'; the link to the router was down {counted(count, "time")}, {seconds:.1f} s in all: '
        'messages published meanwhile are not in the bag'
    )


# --- play --------------------------------------------------------------------------------------


def _status(player: Player) -> str:
    state = 'PAUSED ' if player.paused else 'PLAYING'
    elapsed = max(0, player.clock.now() - player.start_ns) / 1e9
    total = max(0, player.end_ns - player.start_ns) / 1e9
    return (
        f'[{state}] bag time {player.clock.now() / 1e9:.3f}  {elapsed:.1f}/{total:.1f} s  '
        f'rate {player.rate:.2f}  {counted(player.published, "message")}'
    )


def _on_key(player: Player, key: str) -> bool:
    """Steer the player from a key; False to quit."""
    if key == ' ':
        player.toggle_pause()
    elif key in ('right', 's'):
        player.step()
    elif key == 'up':
        player.set_rate(player.rate * 1.1)
    elif key == 'down':
        player.set_rate(player.rate / 1.1)
    elif key in ('q', 'Q'):
        return False
    return True


def play(args: argparse.Namespace) -> int:
    from zros.bag.play.player import Player
    from zros.bag.progress import Keys, Progress

    clock: bool | float = False if args.clock is None else args.clock
    stop = threading.Event()
    progress = Progress()
    with stop_on_signals(stop), open_node(args) as node:
        player = Player(
            node,
            args.path,
            rate=args.rate,
            start_offset=args.start_offset,
            loop=args.loop,
            topics=args.topics,
            remap=args.remap,
            clock=clock,
            wait_for_subscribers=args.wait_for_subscribers,
        )
        with player, Keys() as keys:
            source = player.source
            count = sum(c.count for c in player.connections)
            out(
                f'Playing {source.path}: {counted(count, "message")} on '
                f'{counted(len(player.topics), "topic")}, {source.duration_ns / 1e9:.3f} s'
            )
            if keys.enabled:
                progress.close()
                progress.stream.write(
                    'space: pause/resume, right arrow: next message, up/down: rate, q: quit\n'
                )
            player.start(paused=args.start_paused)
            while not stop.is_set():
                if keys.enabled:
                    key = keys.read(0.1)
                    if (key is not None and not _on_key(player, key)) or player.done:
                        break
                elif player.wait(0.1):
                    break
                progress.update(_status(player))
            progress.close()
            player.stop()
        if player.error is not None:
            raise CommandError(f'playing {args.path} failed: {player.error}')
        out(f'Played {counted(player.published, "message")}')
    return 0


# --- the parser --------------------------------------------------------------------------------


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f'must be positive, got {text}')
    return value


# --- the parser ------------------------------------------------------------------------------


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    verbs = add_verbs(commands, 'bag', help_line)

    show = verbs.add_parser(
        'info',
        help='print what a recording holds',
        description='Print the files, size, time range and topics of a recording, laid out as '
        '`ros2 bag info` lays them out. Reads ROS 2 bag folders, .mcap and .db3 files, and '
        'ROS 1 .bag files.',
    )
    show.add_argument('path', help='a bag folder, .mcap, .db3 or ROS 1 .bag file')
    show.add_argument(
        '--sort',
        choices=('name', 'type', 'count'),
        default='name',
        help='order of the topics (default name)',
    )
    show.set_defaults(run=info)

    fix = verbs.add_parser(
        'reindex',
        help='make a bag a killed recorder left, or a damaged one, readable again',
        description='Finish every MCAP file of a bag that was never finished (a recorder killed '
        'with SIGKILL, a power loss) into one holding its messages up to the last complete '
        "chunk (and the whole messages of a last chunk the file's end cuts short), with "
        'summary, indexes and footer, and rewrite metadata.yaml from the files, '
        'as `ros2 bag reindex` does. Finished files are left as they are; an unfinished one is '
        'rewritten into a temporary file renamed over it once complete, so a failure leaves '
        'the original unchanged. A file with a damaged chunk, and a ROS 1 .bag cut short or '
        'damaged, is rebuilt the same way from what reads; the report says how many messages '
        'could not be kept. The original of each file rewritten is kept beside it as '
        'NAME.orig.EXT. A file of which no message reads though it holds data is left as it '
        'is and the command exits 1. Not for a bag still being recorded.',
    )
    fix.add_argument('path', help='a bag folder, .mcap or ROS 1 .bag file')
    fix.add_argument(
        '--no-backup',
        action='store_true',
        help='do not keep the original of a file rewritten (NAME.orig.EXT)',
    )
    fix.set_defaults(run=reindex)

    # --- record and play ---------------------------------------------------------------------

    help_text = 'record topics into a bag (rosbag2 MCAP)'
    parser = verbs.add_parser('record', help=help_text, description=help_text)
    parser.set_defaults(run=record)
    add_connection_options(parser)
    parser.add_argument('topics', nargs='*', metavar='TOPIC', help='topics to record')
    parser.add_argument('-a', '--all', action='store_true', help='every topic, also later ones')
    parser.add_argument('-e', '--regex', metavar='REGEX', help='topics whose name matches')
    parser.add_argument('-o', '--output', metavar='FOLDER',
                        help='the bag folder (default: rosbag2_<date>-<time>)')  # fmt: skip
    parser.add_argument('-b', '--max-bag-size', type=int, default=0, metavar='BYTES',
                        help='split files at this size (0: never)')  # fmt: skip
    parser.add_argument('-d', '--max-bag-duration', type=float, default=0, metavar='S',
                        help='split files after this many seconds (0: never)')  # fmt: skip
    parser.add_argument('--compression', choices=('zstd', 'lz4', 'none'), default='zstd',
                        help='chunk compression (default zstd)')  # fmt: skip
    parser.add_argument('--include-hidden-topics', action='store_true',
                        help='with -a or -e, also topics with a part starting with _')  # fmt: skip

    help_text = 'play a bag into the graph'
    parser = verbs.add_parser('play', help=help_text, description=help_text)
    parser.set_defaults(run=play)
    add_connection_options(parser)
    parser.add_argument('path', help='bag folder, .mcap, .db3 or ROS 1 .bag')
    parser.add_argument('-r', '--rate', type=_positive, default=1.0, help='speed (default 1)')
    parser.add_argument('--start-offset', type=float, default=0.0, metavar='S',
                        help='skip this many seconds from the start')  # fmt: skip
    parser.add_argument('-l', '--loop', action='store_true', help='play again and again')
    parser.add_argument('--topics', nargs='+', metavar='TOPIC', help='only these topics')
    parser.add_argument('--remap', nargs='+', action='extend', metavar='FROM:=TO',
                        help='rename topics, e.g. /chatter:=/talk')  # fmt: skip
    parser.add_argument('--clock', nargs='?', type=_positive, const=40.0, metavar='HZ',
                        help='publish /clock with the bag time (default 40 Hz)')  # fmt: skip
    parser.add_argument('--start-paused', action='store_true', help='start paused')
    parser.add_argument('--wait-for-subscribers', type=float, default=0.5, metavar='S',
                        help='wait up to S seconds for each topic to have a subscriber '
                        '(default 0.5)')  # fmt: skip

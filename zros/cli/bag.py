"""``zros bag``: info and reindex (as ``ros2 bag info`` and ``ros2 bag reindex``); record and
play are added beside them."""

from __future__ import annotations

import argparse

from zros.cli.shared import out


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    bag = commands.add_parser('bag', help=help_line)
    verbs = bag.add_subparsers(dest='verb', metavar='VERB', required=True)

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
    show.set_defaults(run='zros.cli.bag:info')

    fix = verbs.add_parser(
        'reindex',
        help='make a bag a killed recorder left readable again',
        description='Finish every MCAP file of a bag that was never finished (a recorder killed '
        'with SIGKILL, a power loss) into one holding its messages up to the last complete '
        'chunk, with summary, indexes and footer, and rewrite metadata.yaml from the files, '
        'as `ros2 bag reindex` does. Finished files are left as they are; an unfinished one is '
        'rewritten into a temporary file renamed over it once complete, so a failure leaves '
        'the original unchanged. Not for a bag still being recorded.',
    )
    fix.add_argument('path', help='a bag folder or .mcap file')
    fix.set_defaults(run='zros.cli.bag:reindex')

    # --- record and play: verbs of zros.cli.bag_record_play go here -------------------------
    from zros.cli.bag_record_play import add_verbs

    add_verbs(verbs)


def info(args: argparse.Namespace) -> int:
    from zros.bag.read.info import info as read_info

    out(read_info(args.path).format(args.sort))
    return 0


def reindex(args: argparse.Namespace) -> int:
    from zros.bag.write.reindexer import reindex as reindex_bag

    out(str(reindex_bag(args.path)))
    return 0

"""``zros topic``: list, info, type, find, echo, pub, hz, bw, delay (as ``ros2 topic``)."""

from __future__ import annotations

import argparse
import builtins
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, cast

from zros.cli.graph_lookup import (
    add_listing_options,
    find_names,
    graph_topic_type,
    listed,
    require_advertised_type,
    subscription_type,
    unknown_name,
)
from zros.cli.qos_options import add_qos_options, chosen_qos
from zros.cli.shared import (
    DISCOVERY,
    CommandError,
    UsageError,
    add_verb,
    add_verbs,
    add_wait_option,
    build_message,
    message_class,
    open_node,
    out,
    parse_values,
)
from zros.cli.topic_rates import bw, delay, hz
from zros.qos import DEFAULT, LATCHED, Congestion, Durability, Priority, QoS

if TYPE_CHECKING:
    from zros.cdr import Message
    from zros.graph import Endpoint
    from zros.node import Node
    from zros.pubsub.publisher import Publisher

#: what lists the topics, named when a mistyped one matches none
LIST = 'zros topic list'
#: where ``topic echo`` cuts arrays, bytes and strings unless ``--full-length`` (as ros2)
TRUNCATE = 128
#: what ``topic echo`` subscribes with unless told (deep: a burst is not lost to the terminal)
ECHO_QOS = QoS(100)


def _publishers_and_subscribers(node: Node, topic: str) -> tuple[list[Endpoint], list[Endpoint]]:
    key = node.scheme.key(node.resolve_name(topic))
    return node.graph.publishers(key), node.graph.subscribers(key)


# --- one-shot commands -----------------------------------------------------------------------


def list_topics(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        node.graph.refresh(DISCOVERY)
        topics = listed(args, node.graph.topics(node.scheme.namespace))
        if args.count:
            out(str(len(topics)))
            return 0
        if args.verbose:
            for title, kind in (('Published topics', 0), ('Subscribed topics', 1)):
                out(f'{title}:')
                for name, types in topics.items():
                    ends = _publishers_and_subscribers(node, name)[kind]
                    if ends:
                        noun = 'publisher' if kind == 0 else 'subscriber'
                        count = len(ends)
                        plural = '' if count == 1 else 's'
                        out(f' * {name} [{", ".join(types)}] {count} {noun}{plural}')
                out()
            return 0
        for name, types in topics.items():
            out(f'{name} [{", ".join(types)}]' if args.show_types else name)
    return 0


def info(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        node.graph.refresh(DISCOVERY)
        name = node.resolve_name(args.topic)
        types = node.graph.topics(node.scheme.namespace).get(name)
        if not types:
            raise unknown_name('topic', name, node.graph.topics(node.scheme.namespace), LIST)
        publishers, subscribers = _publishers_and_subscribers(node, name)
        out(f'Type: {", ".join(types)}')
        out()
        for title, ends in (('Publisher count', publishers), ('Subscription count', subscribers)):
            out(f'{title}: {len(ends)}')
            if args.verbose:
                out()
                for end in ends:
                    owner = end.node or f'(bridge {end.zid})'
                    out(f'Node name: {owner}')
                    out(f'Topic type: {end.type_name}')
                    out(f'Endpoint type: {"PUBLISHER" if end in publishers else "SUBSCRIPTION"}')
                    out(f'Zenoh session: {end.zid}')
                    out(f'QoS profile: {end.qos}')
                    out()
            elif title.startswith('Publisher'):
                out()
    return 0


def topic_type(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        out(graph_topic_type(node, args.topic, None))  # a name not found: the closest
    return 0


def find(args: argparse.Namespace) -> int:
    return find_names(args, 'topics', message_class(args.type).__msgtype__)


# --- echo and pub ----------------------------------------------------------------------------


def _filter(expression: str | None) -> Callable[[object], bool] | None:
    """ros2's ``--filter``: a Python expression on ``m``, evaluated (as ros2 does) on each
    message; a syntax error is a usage error, an expression failing on a message fails."""
    if expression is None:
        return None
    try:
        code = compile(expression, '--filter', 'eval')
    except SyntaxError as exc:
        raise UsageError(f'--filter {expression!r} is not a Python expression: {exc.msg}') from None

    def check(m: object) -> bool:
        try:
            return bool(eval(code, {'__builtins__': builtins}, {'m': m}))  # as ros2's
        except Exception as exc:  # the user's expression: any error
            name = type(exc).__name__
            raise CommandError(
                f'--filter {expression!r} failed on a message: {name}: {exc}'
            ) from None

    return check


def echo(args: argparse.Namespace) -> int:
    from zros.cdr import CdrError
    from zros.cdr.message import Message, decode
    from zros.cli.echo_tap import EchoTap
    from zros.cli.message_text import message_to_csv, message_to_yaml, select, value_to_yaml

    truncate = None if args.full_length else args.truncate_length
    options = {'truncate': truncate, 'no_arr': args.no_arr, 'no_str': args.no_str}
    keep = _filter(args.filter_expr)
    tapped = args.raw or args.include_message_info
    if args.raw and args.field:
        raise UsageError('--raw prints the whole message as bytes: no --field')
    if tapped and args.max_age is not None:
        raise UsageError('--max-age does not combine with --raw or --include-message-info')

    def selected(message: Message) -> object:
        try:
            return select(message, args.field) if args.field else message
        except KeyError as exc:
            raise CommandError(str(exc.args[0])) from None

    def text_of(value: object) -> str:
        if args.csv:
            return message_to_csv(value, **options) if isinstance(value, Message) else str(value)
        if isinstance(value, Message):
            return message_to_yaml(value, flow_style=args.flow_style, **options)
        return value_to_yaml(value, flow_style=args.flow_style, **options)

    def show(value: object, info: dict[str, int] | None) -> None:
        if isinstance(value, bytes):  # --raw, as ros2 prints the bytes
            if info is not None:
                out('---Got new message, message info:---')
                out(str(info))
                out('---Message data:---')
            out(repr(value))
            out('---')
        elif args.csv:
            prefix = '' if info is None else ','.join(map(str, info.values())) + ','
            out(prefix + text_of(value).rstrip('\n'))
        else:
            if info is not None:  # as ros2's yaml.dump: sorted keys
                out('\n'.join(f'{key}: {info[key]}' for key in sorted(info)))
                out('---')
            out(text_of(value).rstrip('\n'))
            out('---')

    with open_node(args) as node:
        type_name = subscription_type(node, args.topic, args.type, args.wait)
        cls = node.registry.get_class(type_name)
        selected(cls())  # a wrong --field fails before a message
        publishers = _publishers_and_subscribers(node, args.topic)[0]
        offered = [p.qos for p in publishers if p.qos is not None]
        qos = chosen_qos(args, ECHO_QOS, offered).with_(lifespan=args.max_age)
        if tapped:
            tap = EchoTap(node, args.topic, type_name, qos)

            def receive() -> tuple[object, dict[str, int] | None] | None:
                got = tap.next(0.5)
                if got is None:
                    return None
                data, info = got[0], got[1] if args.include_message_info else None
                if args.raw:
                    return data, info
                try:
                    return selected(decode(cls, data)), info
                except CdrError as exc:
                    print(f'zros: a message does not decode as {type_name}: {exc}', file=sys.stderr)
                    return None
        else:
            subscriber = node.create_subscription(type_name, args.topic, qos=qos)

            def receive() -> tuple[object, dict[str, int] | None] | None:
                message = subscriber.wait_for_message(timeout=0.5)
                return None if message is None else (selected(message), None)

        printed = 0
        try:
            while node.ok():
                got = receive()
                if got is None or (keep is not None and not keep(got[0])):
                    continue
                show(*got)
                printed += 1
                if args.once or (args.count and printed >= args.count):
                    break
        except KeyboardInterrupt:
            pass
    return 0


#: where ``pub`` puts the time: a path of field names and sequence indexes to a Time field
StampPath = tuple[str | int, ...]


def _expand_stamps(cls: type[Message], values: dict[str, object]) -> list[StampPath]:
    """Take ``header: auto`` (a std_msgs/Header field) and ``stamp: now`` (a
    builtin_interfaces/Time field) out of ``values`` as ``ros2 topic pub`` does: an empty
    message in their place, and the paths of the Time fields to set to now at each publish."""
    from zros.cdr.message import definition_of

    paths: list[StampPath] = []

    def walk(cls: type[Message], values: dict[str, object], path: StampPath) -> None:
        types = {field.name: field.type for field in definition_of(cls).fields}
        for name, value in values.items():
            field_type = types.get(name)
            if field_type is None or not field_type.is_nested:
                continue  # from_dict names a wrong field
            if field_type.is_scalar:
                if field_type.base == 'std_msgs/msg/Header' and value == 'auto':
                    values[name] = {}
                    paths.append((*path, name, 'stamp'))
                elif field_type.base == 'builtin_interfaces/msg/Time' and value == 'now':
                    values[name] = {}
                    paths.append((*path, name))
                elif isinstance(value, dict):
                    walk(message_class(field_type.base), value, (*path, name))
            elif isinstance(value, list):
                element = message_class(field_type.base)
                for index, item in enumerate(value):
                    if isinstance(item, dict):
                        walk(element, item, (*path, name, index))

    walk(cls, values, ())
    return paths


def _stamp(message: Message, paths: list[StampPath], now: Message) -> None:
    """Set the Time fields at ``paths`` (from :func:`_expand_stamps`) to ``now``."""
    for path in paths:
        owner: object = message
        for step in path[:-1]:
            owner = (
                cast('list[object]', owner)[step] if isinstance(step, int) else getattr(owner, step)
            )
        setattr(owner, str(path[-1]), now)


def _wait_for_subscribers(
    node: Node, publisher: Publisher, wanted: int, timeout: float | None
) -> bool:
    """Wait until ``wanted`` subscribers of the publisher's topic show in the graph (saying so
    each second, as ros2) and one matches the publisher, for ever unless ``timeout``; whether
    they did (False after Ctrl-C)."""
    deadline = None if timeout is None else time.monotonic() + timeout

    def found() -> int:
        return len(_publishers_and_subscribers(node, publisher.topic)[1])

    while found() < wanted:
        if not node.ok():
            return False
        remaining = 1.0 if deadline is None else deadline - time.monotonic()
        if remaining <= 0:
            raise CommandError(
                f'{publisher.topic}: {found()} of the {wanted} subscriber(s) waited for showed '
                f'within {timeout:g} s'
            )
        out(f'Waiting for at least {wanted} matching subscription(s)...')
        node.graph.wait_until(lambda: found() >= wanted, min(remaining, 1.0))
    # the graph shows them a moment before Zenoh routes to them: a put before would be lost
    return publisher.wait_for_subscribers(DISCOVERY) or node.ok()


def pub(args: argparse.Namespace) -> int:
    cls = message_class(args.type)
    values = parse_values(args.values)
    stamps = _expand_stamps(cls, values)
    message = build_message(cls, values)
    times = 1 if args.once else args.times
    wanted = args.wait_matching_subscriptions
    if wanted is None:  # as ros2: one when it sends a number of messages (not when latched)
        wanted = int(times != 0 and not args.latched)
    if args.max_wait_time_secs is not None and not wanted:
        raise UsageError('--max-wait-time-secs needs a subscriber to wait for (-w N, -1 or -t)')
    with open_node(args) as node:
        require_advertised_type(node, 'topics', args.topic, cls.__msgtype__)
        qos = chosen_qos(args, LATCHED if args.latched else DEFAULT, None).with_(
            priority=args.priority, express=args.express, congestion=args.congestion
        )
        if args.latched and args.qos_durability is None:  # over --qos-profile's too
            qos = qos.with_(durability=Durability.TRANSIENT_LOCAL)
        publisher = node.create_publisher(cls, args.topic, qos=qos)
        if wanted and not _wait_for_subscribers(node, publisher, wanted, args.max_wait_time_secs):
            return 0  # Ctrl-C
        out('publisher: beginning loop')
        rate = node.create_rate(args.rate) if args.rate > 0 else None
        sent = 0
        try:
            while node.ok():
                sent += 1
                if stamps:
                    _stamp(message, stamps, node.now().to_msg())
                out(f'publishing #{sent}: {message!r}')
                out()
                publisher.write(message)
                if times and sent >= times:
                    break
                if rate is not None:
                    rate.sleep()
        except KeyboardInterrupt:
            pass
        if args.once or qos.transient_local:
            # give late subscribers of a latched topic, and the network, a moment
            node.spin(timeout=0.3 if not qos.transient_local else args.keep_alive)
    return 0


# --- the parser ------------------------------------------------------------------------------


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    verbs = add_verbs(commands, 'topic', help_line)

    listing = add_verb(verbs, 'list', 'list the topics on the network', list_topics)
    listing.add_argument('-t', '--show-types', action='store_true', help='with their types')
    listing.add_argument('-v', '--verbose', action='store_true', help='publishers, subscribers')
    add_listing_options(listing, 'topics')

    parser = add_verb(verbs, 'info', 'type and endpoints of a topic', info)
    parser.add_argument('topic')
    parser.add_argument('-v', '--verbose', action='store_true', help='each endpoint')

    parser = add_verb(verbs, 'type', 'the type of a topic', topic_type)
    parser.add_argument('topic')

    parser = add_verb(verbs, 'find', 'the topics of a type', find)
    parser.add_argument('type')
    add_listing_options(parser, 'topics')

    parser = add_verb(verbs, 'echo', 'print the messages of a topic', echo)
    parser.add_argument('topic')
    parser.add_argument('type', nargs='?', help='its type (default: from the network)')
    parser.add_argument('--field', help='print only this field, e.g. pose.position')
    parser.add_argument('--once', action='store_true', help='print one message and exit')
    parser.add_argument('--count', type=int, default=0, help='exit after N messages')
    parser.add_argument('--csv', action='store_true', help='comma-separated values')
    parser.add_argument('--no-arr', action='store_true', help='abbreviate arrays')
    parser.add_argument('--no-str', action='store_true', help='abbreviate strings')
    parser.add_argument('--flow-style', action='store_true', help='arrays on one line')
    parser.add_argument(
        '--filter', dest='filter_expr', metavar='EXPR',
        help='print only messages for which this Python expression on m (the message, or the '
        'field of --field) is true, e.g. "m.data > 3"; evaluated as Python, as ros2 does: '
        'never pass text you do not trust',
    )  # fmt: skip
    parser.add_argument('--raw', action='store_true', help='print the CDR bytes, as ros2')
    parser.add_argument(
        '-i', '--include-message-info', action='store_true',
        help="each message's info first (as ros2: source and received timestamps, in ns, the "
        "publisher's sequence number, 0 when the wire carries none, and the count here)",
    )  # fmt: skip
    parser.add_argument(
        '-l', '--truncate-length', type=_count, default=TRUNCATE, metavar='N',
        help=f'cut arrays, bytes and strings after N items, marked ... (default {TRUNCATE})',
    )  # fmt: skip
    parser.add_argument(
        '-f', '--full-length', action='store_true', help='print arrays and strings in full'
    )
    add_qos_options(
        parser, 'subscribe',
        f'depth {ECHO_QOS.depth}; reliability and durability not given match the publishers',
    )  # fmt: skip
    _add_max_age(parser)
    add_wait_option(parser, 'topic')

    parser = add_verb(verbs, 'pub', 'publish messages on a topic', pub)
    parser.add_argument('topic')
    parser.add_argument('type')
    parser.add_argument(
        'values', nargs='?',
        help='YAML, e.g. "{data: hello}"; "{header: auto}" and "{stamp: now}" stamp each message',
    )  # fmt: skip
    parser.add_argument('-r', '--rate', type=float, default=1.0, help='Hz (default 1; 0: no wait)')
    parser.add_argument('-1', '--once', action='store_true', help='publish once and exit')
    parser.add_argument('-t', '--times', type=int, default=0, help='publish N times and exit')
    parser.add_argument('--latched', action='store_true', help='transient local, like /tf_static')
    parser.add_argument('--keep-alive', type=float, default=1.0, metavar='S',
                        help='latched: seconds to stay for late subscribers')  # fmt: skip
    add_qos_options(
        parser, 'publish', 'reliable, volatile, depth 10; --latched: transient local, depth 1'
    )
    parser.add_argument(
        '-w', '--wait-matching-subscriptions', type=_count, metavar='N',
        help='wait for N subscribers first (default: 1 with -1 or -t unless --latched, else 0)',
    )  # fmt: skip
    parser.add_argument(
        '--max-wait-time-secs', type=_seconds, metavar='S',
        help='fail if they do not show within S seconds (default: wait for ever)',
    )  # fmt: skip
    parser.add_argument(
        '--priority', choices=[p.name.lower() for p in Priority],
        help="Zenoh's priority (default: by topic and type, docs/qos.md)",
    )  # fmt: skip
    parser.add_argument(
        '--express', action=argparse.BooleanOptionalAction, default=None,
        help='send each message at once, unbatched (default: for urgent ones)',
    )  # fmt: skip
    parser.add_argument(
        '--congestion', choices=[c.value for c in Congestion],
        help='what write() does on a full link (default: drop; docs/qos.md)',
    )  # fmt: skip

    for name, help_text, target in (
        ('hz', 'the rate of a topic', hz),
        ('bw', 'the bandwidth of a topic', bw),
        ('delay', 'the delay of a topic from its header stamps', delay),
    ):
        parser = add_verb(verbs, name, help_text, target)
        parser.add_argument('topic')
        if name == 'delay':
            parser.add_argument('type', nargs='?')
        add_wait_option(parser, 'topic')
        parser.add_argument('-w', '--window', type=int, default=10_000 if name == 'hz' else 100)
        if name != 'delay':
            _add_max_age(parser)
        parser.add_argument('--period', type=float, default=1.0, help='seconds between reports')
        parser.add_argument('--count', type=int, default=0, help='exit after N reports')


def _count(text: str) -> int:
    """An argparse type: a whole number >= 0."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f'must be 0 or more, not {text}')
    return value


def _seconds(text: str) -> float:
    """An argparse type: a number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        value = 0.0
    if not value > 0:
        raise argparse.ArgumentTypeError(f'a number of seconds > 0, not {text}')
    return value


def _add_max_age(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        '--max-age', type=_seconds, metavar='S',
        help='drop messages older than S seconds on arrival, counted and logged (a lifespan)',
    )  # fmt: skip

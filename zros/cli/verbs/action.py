"""``zros action``: list, info, type, send_goal (as ``ros2 action``)."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from zros.cli.graph_lookup import (
    add_listing_options,
    list_names,
    print_types,
    require_advertised_type,
    require_on_graph,
)
from zros.cli.shared import (
    WAIT,
    CommandError,
    add_verb,
    add_verbs,
    add_wait_option,
    build_message,
    errors_tell_of_lost_links,
    open_node,
    out,
    parse_values,
)
from zros.errors import command_line_text

if TYPE_CHECKING:
    from zros.actions.client import ClientGoalHandle
    from zros.cdr import Message

#: after the result, callbacks still arriving within this many seconds of each other run
FEEDBACK_SETTLE = 0.2
#: how long Ctrl-C waits for the server to answer the goal's cancel
CANCEL_WAIT = 5.0


def _indented(text: str, spaces: int = 4) -> str:
    return '\n'.join(' ' * spaces + line if line else line for line in text.rstrip().split('\n'))


def list_actions(args: argparse.Namespace) -> int:
    return list_names(args, 'actions')


def action_type(args: argparse.Namespace) -> int:
    return print_types(args, 'actions', args.action)


def info(args: argparse.Namespace) -> int:
    from zros.keyexpr.kinds import EntityKind

    with open_node(args) as node:
        name = node.resolve_name(args.action)
        key = node.scheme.key(name)
        require_on_graph(node, 'actions', name)
        out(f'Action: {name}')
        for title, kind in (
            ('Action clients', EntityKind.ACTION_CLIENT),
            ('Action servers', EntityKind.ACTION_SERVER),
        ):
            ends = [e for e in node.graph.endpoints((kind,)) if e.key == key]
            out(f'{title}: {len(ends)}')
            for end in ends:
                owner = end.node or f'(bridge {end.zid})'
                out(f'    {owner} [{end.type_name}]' if args.show_types else f'    {owner}')
    return 0


def _cancel(handle: ClientGoalHandle) -> int:
    """Ctrl-C during a goal: cancel it as ros2 does, waiting briefly for the server's answer
    (a second Ctrl-C ends the wait); exit code 130."""
    from zros.runtime.signal import clear_interrupt
    from zros.services import ServiceError

    if handle.status.terminal:
        return 130
    out('Canceling goal...')
    clear_interrupt()  # the Ctrl-C ended every wait of the node's: let the cancel's be awaited
    try:
        canceled = handle.cancel(timeout=CANCEL_WAIT)
    except ServiceError as exc:
        print(f'zros: error: cannot cancel the goal: {command_line_text(exc)}', file=sys.stderr)
        return 130
    if canceled:
        out('Goal canceled.')
    else:
        print('zros: error: the server did not cancel the goal', file=sys.stderr)
    return 130


def send_goal(args: argparse.Namespace) -> int:
    from zros.actions import GoalStatus
    from zros.cdr import default_registry
    from zros.cdr.interfaces import ActionType
    from zros.cli.message_text import message_to_yaml
    from zros.services import ServiceError

    action = default_registry().get_type(args.type)
    if not isinstance(action, ActionType):
        raise CommandError(f'{args.type} is not an action type')
    values = parse_values(args.values)
    with open_node(args) as node:
        if args.wait is None:  # before our own client shows the name on the graph
            require_on_graph(node, 'actions', node.resolve_name(args.action))
        require_advertised_type(node, 'actions', args.action, action.__actiontype__)
        client = node.create_action_client(action, args.action)
        goal = build_message(client.Goal, values)

        def on_feedback(feedback: Message) -> None:
            out('Feedback:')
            out(_indented(message_to_yaml(feedback)))
            out()

        wait = WAIT if args.wait is None else args.wait
        out('Waiting for an action server to become available...')
        if not client.wait_for_server(wait):
            raise CommandError(f'no server for {client.name} appeared within {wait:g} s')
        errors_tell_of_lost_links()
        out('Sending goal:')
        out(_indented(message_to_yaml(goal), 5))
        out()
        try:
            handle = client.send_goal(goal, on_feedback if args.feedback else None)
        except ServiceError as exc:
            raise CommandError(command_line_text(exc)) from None
        if not handle.accepted:
            out('Goal was rejected.')
            return 1
        out(f'Goal accepted with ID: {handle.goal_id.hex()}')
        out()
        try:
            while not handle.done and node.ok():
                node.spin(timeout=0.1)  # runs the feedback callback here; Ctrl-C ends it
            # feedback and result travel apart: feedback sent before the result may still be
            # on its way to the callback; print what comes until a quiet spell
            while node.ok() and node.spin_once(FEEDBACK_SETTLE):
                pass
            if not node.ok():
                raise KeyboardInterrupt  # a spin ended on Ctrl-C
            result = handle.result(0)
        except KeyboardInterrupt:
            return _cancel(handle)
        out('Result:')
        out(_indented(message_to_yaml(result)))
        out()
        out(f'Goal finished with status: {handle.status.name}')
        return 0 if handle.status is GoalStatus.SUCCEEDED else 1


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    verbs = add_verbs(commands, 'action', help_line)

    listing = add_verb(verbs, 'list', 'list the actions on the network', list_actions)
    listing.add_argument('-t', '--show-types', action='store_true', help='with their types')
    add_listing_options(listing, 'actions', hidden=False)
    add_verb(verbs, 'type', 'the type of an action', action_type).add_argument('action')
    sub = add_verb(verbs, 'info', 'the clients and servers of an action', info)
    sub.add_argument('action')
    sub.add_argument('-t', '--show-types', action='store_true', help='with their types')
    sub = add_verb(verbs, 'send_goal', 'send a goal and print its result', send_goal)
    sub.add_argument('action', help='e.g. /fibonacci')
    sub.add_argument('type', help='e.g. example_interfaces/action/Fibonacci')
    sub.add_argument('values', nargs='?', help='the goal as YAML, e.g. "{order: 5}"')
    sub.add_argument('-f', '--feedback', action='store_true', help='print the feedback')
    add_wait_option(sub, 'action')

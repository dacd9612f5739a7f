"""What ``~/get_type_description`` costs a node: start-up time and graph entities.

Medians over ``--runs`` nodes, each made and destroyed on one session through a local router:
a plain node (standard types only: the service does not start), a node whose first publisher
has a custom type with the service (it starts then) and without it
(``start_type_description_service=False``), and the liveliness tokens each one declares.
"""

from __future__ import annotations

import argparse
import statistics
import time

import zros
from zros.cdr.registry import TypeRegistry
from zros.transport import Transport, TransportConfig, start_router

STATUS = 'my_robot_msgs/msg/Status'


def made(transport: Transport, registry: TypeRegistry, msg_type: str, serve: bool) -> float:
    """Seconds to make a node and its first publisher (of ``msg_type``)."""
    started = time.perf_counter()
    node = zros.Node(
        'probe', transport=transport, registry=registry, enable_rosout=False,
        start_parameter_services=False, start_type_description_service=serve,
    )  # fmt: skip
    node.create_publisher(msg_type, '/status', 10)
    elapsed = time.perf_counter() - started
    node.destroy()
    return elapsed


def tokens(transport: Transport, registry: TypeRegistry, msg_type: str, serve: bool) -> int:
    """Liveliness tokens a node with one publisher of ``msg_type`` declares."""
    declared: list[str] = []
    transport.on_token(lambda key, alive: declared.append(key) if alive else None)
    before = len(declared)
    node = zros.Node(
        'probe', transport=transport, registry=registry, enable_rosout=False,
        start_parameter_services=False, start_type_description_service=serve,
    )  # fmt: skip
    node.create_publisher(msg_type, '/status', 10)
    count = len(declared) - before
    node.destroy()
    return count


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--runs', type=int, default=200, help='median of this many nodes')
    options = parser.parse_args()
    registry = TypeRegistry(paths=[], ament=False)
    registry.register_text(STATUS, 'string mode\nfloat64 battery\nint32[] errors\n')
    cases = [
        ('standard type (service not started)', 'std_msgs/msg/String', True),
        ('custom type, service on', STATUS, True),
        ('custom type, service off', STATUS, False),
    ]
    with start_router(shared_memory=False) as router:
        transport = Transport(TransportConfig.create(connect=router.endpoint, shared_memory=False))
        for _, msg_type, serve in cases:  # warm: classes, codecs, hashes
            made(transport, registry, msg_type, serve)
        times: dict[str, list[float]] = {label: [] for label, _, _ in cases}
        for _ in range(options.runs):  # interleaved: the machine's load hits every case alike
            for label, msg_type, serve in cases:
                times[label].append(made(transport, registry, msg_type, serve))
        print(f'{"node + first publisher":<40} {"median ms":>9} {"tokens":>6}')
        for label, msg_type, serve in cases:
            median = statistics.median(times[label]) * 1000
            count = tokens(transport, registry, msg_type, serve)
            print(f'{label:<40} {median:>9.2f} {count:>6}')
        transport.close()


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()

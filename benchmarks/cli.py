"""How fast the ``zros`` command answers: start-up, and ``topic list`` on a large graph.

Goals: ``zros --help`` under 0.1 s (issue 16; issue 9 asked 0.3 s); ``zros topic list`` under
1 s with 500 topics. ``ros2 topic list`` is not installable here (no ros2cli on PyPI), so the
comparison is with the goals and with plain ``python -c pass`` (the interpreter's own start-up,
the floor: in a virtual environment with an editable install, or with a package whose ``.pth``
file runs code at start-up, that floor is higher than for a plain install).

    python benchmarks/cli.py [--topics 500] [--runs 20] [--quick]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

import zros
from zros.transport import Transport, TransportConfig, start_router


def timed(command: list[str], env: dict[str, str], runs: int) -> tuple[float, str]:
    times = []
    output = ''
    for _ in range(runs):
        started = time.perf_counter()
        result = subprocess.run(command, capture_output=True, text=True, env=env, check=True)
        times.append(time.perf_counter() - started)
        output = result.stdout
    return statistics.median(times), output


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--topics', type=int, default=500)
    parser.add_argument('--runs', type=int, default=20, help='median of this many runs')
    parser.add_argument('--quick', action='store_true', help='3 runs, 50 topics (a check)')
    options = parser.parse_args()
    if options.quick:
        options.runs, options.topics = 3, 50
    command = shutil.which('zros', path=str(Path(sys.executable).parent)) or 'zros'
    with start_router(shared_memory=False) as router:
        env = dict(os.environ, ZROS_CONNECT=router.endpoint)
        transport = Transport(TransportConfig.create(connect=router.endpoint, shared_memory=False))
        node = zros.Node('many_topics', transport=transport, enable_rosout=False)
        for index in range(options.topics):
            node.create_publisher('std_msgs/msg/String', f'/topic_{index:03d}', 10)
        rows = [
            ('python -c pass', [sys.executable, '-c', 'pass'], None),
            ('zros --help', [command, '--help'], 0.1),
            ('zros topic echo --help', [command, 'topic', 'echo', '--help'], None),
            (f'zros topic list ({options.topics} topics)', [command, 'topic', 'list'], 1.0),
            ('zros topic list -t', [command, 'topic', 'list', '-t'], 1.0),
        ]
        print(f'{"command":<36} {"median s":>9} {"goal s":>7}  met')
        for label, argv, goal in rows:
            seconds, output = timed(argv, env, options.runs)
            if 'topic list' in label:
                found = output.count('/topic_')
                assert found == options.topics, f'{label} listed {found} topics'
            verdict = '' if goal is None else ('yes' if seconds < goal else 'NO')
            goal_text = '' if goal is None else f'{goal:.1f}'
            print(f'{label:<36} {seconds:>9.3f} {goal_text:>7}  {verdict}')
        node.destroy()
        transport.close()


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()

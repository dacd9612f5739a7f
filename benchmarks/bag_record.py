"""Recording and playing speed: zros.bag.Recorder and Player through one in-process router.

Rows:

  (a) record: 100,000 std_msgs/String messages on 5 topics, published as fast as the recorder
      takes them (reliable, keep all, one publishing thread per topic, in the same process);
      messages per second from the first publish to the last message written, per compression;
      the bag is then checked complete and read back by rosbags;
  (b) play: a bag of 400 messages 1 to 20 ms apart played into a raw subscriber at rates 1
      and 2: the error of each received gap against the recorded gap divided by the rate
      (median, p90, max) and the total span against the expected one.

    python benchmarks/bag_record.py [--quick]
"""

from __future__ import annotations

import argparse
import random
import statistics
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

STRING = 'std_msgs/msg/String'
MS = 1_000_000


def _node(name: str, endpoint: str) -> Any:
    import zros
    from zros.transport import Transport, TransportConfig

    config = TransportConfig.create(connect=endpoint, shared_memory=False)
    return zros.Node(name, transport=Transport(config))


def record(endpoint: str, folder: Path, count: int, compression: str | None) -> dict[str, float]:
    from rosbags.highlevel import AnyReader

    from zros.bag.write.recorder import Recorder

    talker, recording = _node('talker', endpoint), _node('recording', endpoint)
    topics = [f'/stream{i}' for i in range(5)]
    publishers = [talker.create_publisher(STRING, t, 'keep_all') for t in topics]
    path = folder / f'record_{compression}'
    recorder = Recorder(recording, path, topics, compression=compression)
    assert recorder.wait_for_topics(topics, 10)
    for publisher in publishers:
        assert publisher.wait_for_subscribers()
    per_topic = count // len(topics)

    def run(index: int) -> None:
        cls = publishers[index].msg_type
        for n in range(per_topic):
            publishers[index].write(cls(data=f'{index}:{n}'))

    threads = [threading.Thread(target=run, args=(i,)) for i in range(len(topics))]
    began = time.perf_counter()
    for thread in threads:
        thread.start()
    while recorder.message_count < per_topic * len(topics):
        time.sleep(0.001)
    elapsed = time.perf_counter() - began
    for thread in threads:
        thread.join()
    recorder.close()
    with AnyReader([path]) as reader:
        read = sum(1 for _ in reader.messages())
    assert read == per_topic * len(topics), read
    talker.destroy()
    recording.destroy()
    size = sum(f.stat().st_size for f in path.glob('*.mcap'))
    return {'rate': read / elapsed, 'seconds': elapsed, 'bytes': size}


def play(endpoint: str, folder: Path, rate: float) -> dict[str, float]:
    from zros.bag.play.player import Player
    from zros.bag.write.bag_writer import BagTopic, BagWriter
    from zros.cdr import default_registry, encode, new_message

    path = folder / f'play_{rate}'
    rng = random.Random(5)
    stamps = []
    stamp = 1_700_000_000 * 10**9
    with BagWriter(path) as bag:
        index = bag.add_topic(BagTopic.from_registry(default_registry(), '/timed', STRING))
        for n in range(400):
            stamp += rng.randint(1, 20) * MS
            stamps.append(stamp)
            bag.write(index, stamp, encode(new_message(STRING, data=str(n))))
    listening, playing = _node('listening', endpoint), _node('playing', endpoint)
    received: list[int] = []
    subscription = listening.transport.session.declare_subscriber(
        'timed', lambda sample: received.append(time.monotonic_ns())
    )
    with Player(playing, path, rate=rate, wait_for_subscribers=5.0) as player:
        player.play()
    deadline = time.monotonic() + 5
    while len(received) < len(stamps) and time.monotonic() < deadline:
        time.sleep(0.001)
    subscription.undeclare()
    listening.destroy()
    playing.destroy()
    errors = sorted(
        abs((received[i + 1] - received[i]) - (stamps[i + 1] - stamps[i]) / rate) / MS
        for i in range(len(stamps) - 1)
    )
    span = (received[-1] - received[0]) / MS
    expected = (stamps[-1] - stamps[0]) / MS / rate
    return {
        'median': statistics.median(errors),
        'p90': errors[int(len(errors) * 0.9)],
        'max': errors[-1],
        'span': span,
        'expected': expected,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true', help='10,000 messages instead')
    args = parser.parse_args()
    from zros.transport import start_router

    count = 10_000 if args.quick else 100_000
    router = start_router(shared_memory=False)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            print(f'(a) record {count:,} messages on 5 topics')
            print(f'    {"compression":<12} {"msg/s":>10} {"seconds":>8} {"MB":>8}')
            for compression in ('zstd', 'lz4', None):
                row = record(router.endpoint, folder, count, compression)
                print(
                    f'    {compression or "none":<12} {row["rate"]:>10,.0f} '
                    f'{row["seconds"]:>8.2f} {row["bytes"] / 1e6:>8.2f}'
                )
            print('(b) play 400 messages 1-20 ms apart: gap error (ms)')
            print(
                f'    {"rate":<6} {"median":>8} {"p90":>8} {"max":>8} {"span ms":>9} {"expected":>9}'
            )
            for rate in (1.0, 2.0):
                row = play(router.endpoint, folder, rate)
                print(
                    f'    {rate:<6} {row["median"]:>8.3f} {row["p90"]:>8.3f} {row["max"]:>8.3f} '
                    f'{row["span"]:>9.1f} {row["expected"]:>9.1f}'
                )
    finally:
        router.close()


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()

"""An asyncio program: ``async for message in subscriber``, beside other coroutines.

A subscriber is an async iterator: the loop waits for messages without a thread of its own
and without blocking other tasks. ``await node.spin_async()`` would run the node's callbacks and
timers on the same loop; here nothing needs it.

Start ``talker.py`` on the same router or robot (``--connect`` or ``ZROS_CONNECT``). With
neither, this script starts a Zenoh router and a talker task of its own.
"""

from __future__ import annotations

import argparse
import asyncio

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros


async def talk(pub: zros.Publisher) -> None:
    """A talker as a coroutine: one message every 0.1 s, until cancelled."""
    count = 0
    while True:
        pub.write(zros.Message('std_msgs/msg/String', data=f'Hello World: {count}'))
        count += 1
        await asyncio.sleep(0.1)  # other tasks, the listener among them, run meanwhile


async def listen(sub: zros.Subscriber, count: int) -> list[str]:
    """The first ``count`` messages on ``sub`` (all of them while ``count`` is 0)."""
    heard: list[str] = []
    async for message in sub:
        print(f'I heard: "{message.data}"')
        heard.append(message.data)
        if len(heard) == count:
            break
    return heard


async def main(connect: str | None, count: int, seconds: float, own_talker: bool) -> int:
    node = zros.Node('async_listener', connect=connect)
    sub = node.create_subscription('std_msgs/msg/String', '/chatter', qos=10)
    print('listening on /chatter')
    tasks = []
    if own_talker:
        pub = node.create_publisher('std_msgs/msg/String', '/chatter')
        pub.wait_for_subscribers(timeout=5)
        tasks.append(asyncio.create_task(talk(pub)))
    try:
        heard = await asyncio.wait_for(listen(sub, count), seconds or None)
    except asyncio.TimeoutError:
        heard = []
        print(f'nothing for {seconds:g} s')
    for task in tasks:
        task.cancel()
    node.destroy()
    print(f'heard {len(heard)} messages in an asyncio loop')
    return 0 if heard else 1


if __name__ == '__main__':
    parser = argparse.ArgumentParser(
        description='print what arrives on /chatter, with asyncio, until Ctrl-C',
        formatter_class=ShowDefaults,
    )
    add_connect(parser)
    parser.add_argument(
        '--count', type=int, default=0, help='messages to wait for (0: until Ctrl-C)'
    )
    parser.add_argument(
        '--seconds', type=float, default=0.0, help='give up after this long (0: never)'
    )
    args = parser.parse_args()
    router, args.connect = router_unless_given(args.connect, 'a talker task')
    try:
        status = asyncio.run(main(args.connect, args.count, args.seconds, router is not None))
    except KeyboardInterrupt:  # Ctrl-C: asyncio.run cancelled main, which ended the node
        status = 0
    zros.shutdown()  # closes the process's Zenoh session
    if router is not None:
        router.close()
    raise SystemExit(status)

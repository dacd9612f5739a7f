"""``zros demo``: the rosR sensor tutorial, as far as zros runs it today.

Stage 1 of the tutorial builds its messages: the Sharp GP2D120 voltage (``std_msgs/Float32``) and
the distance it converts to (``sensor_msgs/Range``), encoded exactly as a ROS 2 node would.
"""

from __future__ import annotations

import argparse
from typing import Any

from zros import cdr


def _hex(data: bytes) -> str:
    return ' '.join(f'{byte:02x}' for byte in data)


def run(args: argparse.Namespace) -> int:
    """Print the tutorial's messages, their CDR bytes and type hashes."""
    voltage = cdr.new_message('std_msgs/msg/Float32', data=0.8)
    distance: Any = cdr.new_message(
        'sensor_msgs/msg/Range',
        radiation_type=1,
        field_of_view=0.05,
        min_range=0.04,
        max_range=0.30,
        range=0.164,
    )
    distance.header.frame_id = 'sharpGP2D120'
    print('zros demo: the rosR sensor tutorial (stage 1: its messages)')
    for topic, message in (
        ('/sharpGP2D120/Voltage', voltage),
        ('/sharpGP2D120/Distance', distance),
    ):
        data = cdr.encode(message)
        print(f'\n{topic}  [{message.__msgtype__}]  {cdr.type_hash(type(message))}')
        print(f'  sent:     {message}')
        print(f'  {len(data)} bytes of CDR: {_hex(data)}')
        # float32 fields carry float32 precision: 0.8 comes back as 0.800000011920929
        print(f'  received: {cdr.decode(type(message), data)}')
    print(
        '\nNext stages (live topics on an embedded router, the calibration bag, plots) arrive '
        'with the runtime, bag and plot modules.'
    )
    return 0

"""The path a robot drove, from the transforms of a recording: tf without ROS, at numpy speed.

Every robot records ``/tf`` (moving frames: odometry, localisation) and ``/tf_static`` (where
its sensors are mounted). This script

1. writes such a recording, ``robot_path_bag/``: a robot driving a circle of 2 m radius for
   20 s (``odom -> base_link`` at 20 Hz), a localisation correcting its drift once a second
   (``map -> odom``), and a laser mounted 0.2 m ahead (``base_link -> base_laser``, static);
2. fills a ``zros.tf.Buffer`` with the whole recording (``Buffer.from_bag``) and prints the tree;
3. looks up where the laser was, in the map, at every instant the chain changed, in one numpy
   call (``zros.tf.trajectory``), prints a pose per second and the distance driven, and
   draws the path into ``robot_path.png``.

``--bag PATH`` reads your own recording instead (a folder, ``.mcap``, ``.db3`` or ROS 1
``.bag``), with ``--target`` and ``--source`` naming the frames (default ``map`` and
``base_laser``).
"""

from __future__ import annotations

import argparse
import math
import shutil
from pathlib import Path

import numpy as np
from _bootstrap import ShowDefaults
from matplotlib.figure import Figure

import zros
from zros.bag import BagTopic, BagWriter
from zros.cdr import default_registry, encode
from zros.tf import Buffer, trajectory

SECOND = 1_000_000_000
START = 1_700_000_000 * SECOND


def transform(parent: str, child: str, stamp: int, xy: tuple[float, float], yaw: float) -> object:
    t = zros.Message('geometry_msgs/msg/TransformStamped')
    t.header.frame_id, t.child_frame_id = parent, child
    t.header.stamp = zros.Time(stamp).to_msg()
    t.transform.translation.x, t.transform.translation.y = xy
    t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return t


def write_demo_bag(path: Path) -> None:
    """20 s of a robot on a circle, with a drifting odometry that localisation corrects."""
    registry = default_registry()
    message = registry.get_class('tf2_msgs/msg/TFMessage')
    with BagWriter(path) as bag:
        tf = bag.add_topic(BagTopic.from_registry(registry, '/tf', 'tf2_msgs/msg/TFMessage'))
        static = bag.add_topic(
            BagTopic.from_registry(
                registry,
                '/tf_static',
                'tf2_msgs/msg/TFMessage',
                [zros.QoS(1, durability=zros.Durability.TRANSIENT_LOCAL)],
            )
        )
        laser = transform('base_link', 'base_laser', START, (0.2, 0.0), 0.0)
        bag.write(static, START, encode(message(transforms=[laser])))
        for i in range(401):  # 20 Hz odometry: a quarter turn every 5 s
            stamp = START + i * SECOND // 20
            angle = 2 * math.pi * i / 400
            odometry = transform(
                'odom', 'base_link', stamp, (2 * math.sin(angle), 2 - 2 * math.cos(angle)), angle
            )
            transforms = [odometry]
            if i % 20 == 0:  # 1 Hz localisation: the odometry drifted 1 cm a second
                drift = 0.01 * i / 20
                transforms.append(transform('map', 'odom', stamp, (1.0 + drift, 0.5), 0.0))
            bag.write(tf, stamp, encode(message(transforms=transforms)))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.split('\n')[0], formatter_class=ShowDefaults
    )
    parser.add_argument('--bag', type=Path, help='a recording to read (default: write one)')
    parser.add_argument('--target', default='map', help='the fixed frame')
    parser.add_argument('--source', default='base_laser', help='the moving frame')
    parser.add_argument('--output', default='robot_path.png', help='the picture')
    args = parser.parse_args()
    path = args.bag
    if path is None:
        path = Path('robot_path_bag')
        shutil.rmtree(path, ignore_errors=True)
        write_demo_bag(path)
        print(f'wrote {path}/')

    buffer = Buffer.from_bag(path)
    print(buffer.all_frames_as_string(), end='')
    track = trajectory(buffer, args.target, args.source)
    seconds = (track['t'] - track['t'][0]) / SECOND
    yaw = np.degrees(2 * np.arctan2(track['qz'], track['qw']))
    print(f'path of {args.source} in {args.target}: {len(seconds)} poses over {seconds[-1]:.1f} s')
    print('     t [s]      x [m]      y [m]   yaw [deg]')
    shown = np.searchsorted(seconds, np.arange(0.0, seconds[-1] + 1e-9, 1.0))
    for i in shown:
        print(f'{seconds[i]:10.2f} {track["x"][i]:10.3f} {track["y"][i]:10.3f} {yaw[i]:11.1f}')
    driven = np.hypot(np.diff(track['x']), np.diff(track['y'])).sum()
    print(f'drove {driven:.2f} m')

    figure = Figure(figsize=(5, 5))
    axes = figure.add_subplot()
    axes.plot(track['x'], track['y'])
    axes.set_aspect('equal')
    axes.set_xlabel(f'x in {args.target} [m]')
    axes.set_ylabel(f'y in {args.target} [m]')
    axes.set_title(f'{args.source} in {args.target}')
    figure.savefig(args.output)
    print(f'drew the path into {args.output}')


if __name__ == '__main__':
    main()

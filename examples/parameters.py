"""Parameters: declare them with limits, load a YAML file, set them from another node.

A node's parameters live in ``node.parameters``; zros serves them as the six ``rcl_interfaces``
services ROS 2 tools use (``~/get_parameters``, ``~/set_parameters``...) and publishes each
change on ``/parameter_events``. This script plays two programs:

* ``driver``, which declares ``speed`` (a double between 0 and 2), ``wheels.radius``,
  ``wheels.names`` and a read-only ``frame_id``, with values from ``parameters.yaml`` and the
  command line (``-p name:=value``, the highest priority), and refuses negative radii itself;
* ``tool``, another node, which reads and sets the driver's parameters through a parameter
  client, exactly as ``ros2 param`` would, and is refused with ROS 2's reasons.

Then the rosR calls (``zros.param_set/get/type/delete``) on the default node. With
``--connect`` (or ``ZROS_CONNECT``) both nodes join that network, where ROS 2 tools behind a
bridge reach the driver's services; with neither, a router runs inside the script.
"""

from __future__ import annotations

import argparse
import threading
from pathlib import Path

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros
from zros.params import subscribe_parameter_events


def main() -> int:
    parser = argparse.ArgumentParser(
        description='parameters: declare, load, set remotely', formatter_class=ShowDefaults
    )
    add_connect(parser)
    args = parser.parse_args()
    router, args.connect = router_unless_given(args.connect)

    # --- the driver: parameters from the file, then the command line -----------------------
    driver = zros.init(
        'driver',
        connect=args.connect,
        params_file=Path(__file__).with_name('parameters.yaml'),
        args=['--ros-args', '-p', 'wheels.radius:=0.06'],  # as if given on its command line
    )
    speed = driver.declare_parameter(
        'speed', 0.5, description='top speed [m/s]', floating_point_range=(0.0, 2.0, 0.0)
    )
    radius = driver.declare_parameter('wheels.radius', 0.1)
    names = driver.declare_parameter('wheels.names', ['a', 'b'])
    frame = driver.declare_parameter('frame_id', 'odom', read_only=True)
    print(
        f'driver: speed={speed} (file), wheels.radius={radius} (command line), '
        f'wheels.names={names}, frame_id={frame!r} (read-only)'
    )

    def check(changes: list[zros.params.Parameter]) -> object:  # runs where the driver spins
        for change in changes:
            if change.name == 'wheels.radius' and change.value <= 0:
                return False, 'a wheel radius must be positive'
        return True

    driver.add_on_set_parameters_callback(check)
    threading.Thread(target=zros.spin, daemon=True).start()  # set callbacks run in here

    # --- the tool: another node, reaching the driver over the network ----------------------
    tool = zros.Node('tool', connect=args.connect)
    events: list[str] = []
    subscribe_parameter_events(tool, lambda e: events.append(f'{e.node}: {e.changed}'), '/driver')
    remote = tool.parameter_client('/driver')
    print('tool: the driver has', remote.list_parameters())
    remote.set('speed', 1.5)
    print('tool: set speed to 1.5; the driver now has', driver.get_parameter('speed'))
    for name, value in [('speed', 5.0), ('frame_id', 'map'), ('wheels.radius', -1.0)]:
        try:
            remote.set(name, value)
        except zros.ParameterError as refusal:
            print(f'tool: setting {name} to {value!r} was refused: {refusal}')
    tool.spin_once(timeout=0.5)  # parameter events run as callbacks of the tool
    print('tool: parameter events from /driver:', events)

    # --- the rosR calls, on the default node (the driver) or another one -------------------
    zros.param_set('gain', 3)  # ros.ParamSet: declares it when new
    print('rosR: gain =', zros.param_get('gain'), 'of type', zros.param_type('gain'))
    print("rosR: another node's, /tool:use_sim_time =", zros.param_get('/tool:use_sim_time'))
    zros.param_delete('gain')
    print('rosR: gain after param_delete =', zros.param_get('gain', default=None))

    print('the driver as a ROS 2 parameter file:')
    print(driver.parameters.dump())
    tool.destroy()
    zros.shutdown()
    if router is not None:
        router.close()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())

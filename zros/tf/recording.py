"""Trajectories from recordings, as columns.

``zros.bag`` sits below ``zros.tf`` (the layers of DESIGN.md), so the bag cannot offer a
``Bag.trajectory`` method itself: :func:`trajectory` takes the bag as its first argument.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from zros.bag import Bag
from zros.tf.buffer import Buffer
from zros.tf.tree import clean_frame

if TYPE_CHECKING:
    from zros.tf.quaternions import Floats, Stamps


def trajectory(
    bag: Bag | str | Path | Buffer,
    target_frame: str,
    source_frame: str,
    times: Stamps | Sequence[int] | None = None,
) -> dict[str, Floats | Stamps]:
    """The pose of ``source_frame`` in ``target_frame`` over a recording, as columns ``t``
    (int64 ns), ``x``, ``y``, ``z``, ``qx``, ``qy``, ``qz``, ``qw``.

    ``times`` (int64 ns) default to every stamp at which a moving edge of the chain has a
    transform while the whole chain is known; a chain of static edges alone gives one row,
    at time 0, and moving edges that share no instant raise ExtrapolationException. Stamps
    the chain does not cover give NaN rows.
    ``bag`` may be a path, an open :class:`~zros.bag.Bag`, or a buffer made with
    :meth:`Buffer.from_bag` (to look up several chains without reading the bag again).
    """
    buffer = bag if isinstance(bag, Buffer) else Buffer.from_bag(bag)
    target = clean_frame(target_frame, 'target_frame')
    source = clean_frame(source_frame, 'source_frame')
    stamps = buffer.stamps(target, source) if times is None else np.asarray(times, dtype=np.int64)
    if times is None and not len(stamps) and target != source:
        # no moving edge: the chain is one constant, given once at time 0 (as tf2_echo shows a
        # static chain "At time 0.0"); moving edges that never overlap raise, saying so
        found = buffer.lookup_transform(target, source, 0)
        if found.header.stamp.sec == 0 and found.header.stamp.nanosec == 0:
            stamps = np.zeros(1, dtype=np.int64)
    translations, rotations = buffer.lookup_transforms(target, source, stamps)
    return {
        't': stamps,
        'x': translations[:, 0],
        'y': translations[:, 1],
        'z': translations[:, 2],
        'qx': rotations[:, 0],
        'qy': rotations[:, 1],
        'qz': rotations[:, 2],
        'qw': rotations[:, 3],
    }

"""zros's QoS extensions (``zros.qos``) as Zenoh's own values."""

from __future__ import annotations

from zenoh import CongestionControl
from zenoh import Priority as ZenohPriority

from zros.qos import Congestion, Priority

CONGESTION = {
    Congestion.DROP: CongestionControl.DROP,
    Congestion.BLOCK: CongestionControl.BLOCK,
    Congestion.BLOCK_FIRST: CongestionControl.BLOCK_FIRST,
}

PRIORITY = {
    Priority.REAL_TIME: ZenohPriority.REAL_TIME,
    Priority.INTERACTIVE_HIGH: ZenohPriority.INTERACTIVE_HIGH,
    Priority.INTERACTIVE_LOW: ZenohPriority.INTERACTIVE_LOW,
    Priority.DATA_HIGH: ZenohPriority.DATA_HIGH,
    Priority.DATA: ZenohPriority.DATA,
    Priority.DATA_LOW: ZenohPriority.DATA_LOW,
    Priority.BACKGROUND: ZenohPriority.BACKGROUND,
}

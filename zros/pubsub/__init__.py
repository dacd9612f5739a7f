"""Publishers and subscribers of a node, its ``/rosout``, and raw taps on topics.

A subscriber keeps received samples as raw Zenoh payloads in a queue bounded by its QoS depth,
and decodes them only when read: samples overwritten unread cost nothing. Reads never block;
callbacks run when the node spins; ``async for`` works on the same queue.
"""

from zros.pubsub.publisher import Publisher
from zros.pubsub.subscriber import Subscriber

__all__ = ['Publisher', 'Subscriber']

"""tf2's exceptions, as subclasses of :class:`zros.ZrosError`."""

from __future__ import annotations

from zros.errors import ZrosError


class TransformException(ZrosError):
    """Base of every transform lookup error (tf2's ``TransformException``)."""


class LookupException(TransformException):
    """A frame the buffer does not know; the message names the closest known frames."""


class ConnectivityException(TransformException):
    """The two frames are in trees not joined; the message names both roots."""


class ExtrapolationException(TransformException):
    """The requested time is outside what the chain's data covers; the message says both."""


class InvalidArgumentException(TransformException):
    """An argument no lookup can take: an empty frame name, a bad time or array."""


class TimeoutException(TransformException):
    """tf2's name for a wait that ran out. zros's lookups raise what is still missing when
    their ``timeout`` ends (as tf2_ros's buffer does), so none raises this; it is here for
    code that catches it."""

"""The plots' error: a field address's (``zros.bag.AddressError``), under the name plots use."""

from __future__ import annotations

from zros.bag.errors import AddressError

#: an address that names no numeric field, a topic that is absent, a file with no data
PlotError = AddressError

__all__ = ['PlotError']

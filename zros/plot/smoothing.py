"""The moving average a plot applies to its lines (``zros plot --filter``)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt


def moving_average(values: npt.NDArray[np.float64], length: int) -> npt.NDArray[np.float64]:
    """The mean of each value and the ``length - 1`` before it (fewer at the start).

    The filter of the rosR tutorial: causal, so a live line never changes behind its head.
    NaNs (missing elements) are left out of the means.
    """
    if length < 1:
        raise ValueError(f'a moving average needs a length of 1 or more, not {length}')
    values = np.asarray(values, dtype=np.float64)
    present = ~np.isnan(values)
    sums = np.cumsum(np.insert(np.where(present, values, 0.0), 0, 0.0))
    counts = np.cumsum(np.insert(present.astype(np.int64), 0, 0))
    ends = np.arange(1, len(values) + 1)
    starts = np.maximum(ends - length, 0)
    taken = counts[ends] - counts[starts]
    with np.errstate(invalid='ignore', divide='ignore'):
        return np.where(taken > 0, (sums[ends] - sums[starts]) / np.maximum(taken, 1), np.nan)

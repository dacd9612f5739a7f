"""Names for numpy arrays and dtypes whose element type is known at run time only.

They are numpy's own unparametrised types (``np.ndarray`` and ``np.dtype`` stand for these):
a message field's or a bag column's dtype comes from a message definition read at run time, and
numpy's operators are typed per dtype, so a precise parameter would need a cast at each use.
"""

from __future__ import annotations

from typing import Any

import numpy as np

Array = np.ndarray[Any, np.dtype[Any]]  # type: ignore[explicit-any,unused-ignore]  # see the module's docstring
DType = np.dtype[Any]  # type: ignore[explicit-any,unused-ignore]  # as above

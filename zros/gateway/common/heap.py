"""Reusing the C heap's large blocks in a gateway process (glibc).

A gateway copies each message a few times on its way to a client: Zenoh's payload into Python
bytes, those into the Foxglove SDK's frame, the frame into the WebSocket's buffer. glibc gives
blocks of a few megabytes back to the kernel as soon as two of them are free (its trim threshold
follows the largest block freed, and two images pass it), so every copy of a camera image lands
in freshly mapped memory: on 1080p images the gateway spent about 40 % of its CPU time in page
faults and zeroing pages, more than in copying. :func:`keep_large_blocks` fixes the thresholds
so that such blocks are reused: blocks under ``mmap_threshold`` come from the heap, and the heap
keeps up to ``trim_threshold`` bytes free instead of returning them. The cost is that much
memory kept per malloc arena (a few arenas: one per thread that allocates).

It changes the whole process, so it belongs to commands that are a process of their own
(``zros foxglove``), not to a library call.
"""

from __future__ import annotations

import ctypes
import logging
import sys

_log = logging.getLogger('zros.gateway')

#: mallopt parameters (glibc's malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: blocks below this come from the heap (glibc accepts at most 32 MiB on 64-bit systems)
MMAP_THRESHOLD = 32 * 1024 * 1024
#: free bytes each heap keeps before giving memory back to the kernel
TRIM_THRESHOLD = 64 * 1024 * 1024


def keep_large_blocks(
    mmap_threshold: int = MMAP_THRESHOLD, trim_threshold: int = TRIM_THRESHOLD
) -> bool:
    """Make glibc's malloc reuse freed blocks of up to ``mmap_threshold`` bytes and keep up
    to ``trim_threshold`` free bytes per heap; False (nothing changed) where malloc is not
    glibc's or refuses the values."""
    if not sys.platform.startswith('linux'):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # no C library to load, or one without mallopt
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    # musl has a mallopt that does nothing and returns 0: it counts as refused
    kept = bool(mallopt(_M_MMAP_THRESHOLD, mmap_threshold))
    kept = kept and bool(mallopt(_M_TRIM_THRESHOLD, trim_threshold))
    if not kept:
        _log.debug('malloc keeps its own thresholds (mallopt refused)')
    return kept

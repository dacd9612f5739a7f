"""zros.testing's helpers that need no router: peak_memory."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from zros.testing import peak_memory

pytestmark = pytest.mark.skipif(not Path('/proc/self/status').exists(), reason='Linux /proc')

MB = 1 << 20
HOLD = """
import mmap, sys, time
kind, size = sys.argv[1], int(sys.argv[2]) << 20
if kind == 'anonymous':
    held = bytearray(size)
    for at in range(0, size, 4096):
        held[at] = 1
else:
    with open(sys.argv[3], 'rb') as stream:
        held = mmap.mmap(stream.fileno(), 0, access=mmap.ACCESS_READ)
        sum(held[at] for at in range(0, size, 4096))
time.sleep(0.3)
print('held'); print('done', file=sys.stderr)
sys.exit(3)
"""


def test_peaks_of_anonymous_and_file_mapped_memory(tmp_path: Path) -> None:
    anonymous = peak_memory([sys.executable, '-c', HOLD, 'anonymous', '100'])
    assert anonymous.anonymous >= 100 * MB and anonymous.file < 100 * MB
    assert (anonymous.returncode, anonymous.stdout, anonymous.stderr) == (3, 'held\n', 'done\n')
    data = tmp_path / 'data'
    data.write_bytes(b'\1' * (100 * MB))
    mapped = peak_memory([sys.executable, '-c', HOLD, 'file', '100', str(data)])
    assert mapped.file >= 100 * MB and mapped.anonymous < 100 * MB


def test_a_process_past_its_timeout_is_killed() -> None:
    begin = time.monotonic()
    with pytest.raises(subprocess.TimeoutExpired):
        peak_memory([sys.executable, '-c', 'import time; time.sleep(60)'], timeout=0.5)
    assert time.monotonic() - begin < 30

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


#: a parent of 100 MB less than its child, which holds 100 MB
PARENT = """
import subprocess, sys
sys.exit(subprocess.run([sys.executable, '-c', sys.argv[1], 'anonymous', '100']).returncode)
"""


def test_children_are_sampled_when_asked() -> None:
    argv = [sys.executable, '-c', PARENT, HOLD]
    alone = peak_memory(argv)
    assert alone.anonymous < 100 * MB and alone.children_anonymous == alone.total_anonymous == 0
    found = peak_memory(argv, children=True)
    assert found.returncode == 3 and found.anonymous < 100 * MB
    assert found.children_anonymous >= 100 * MB
    assert found.total_anonymous >= found.children_anonymous


def test_a_process_past_its_timeout_is_killed() -> None:
    begin = time.monotonic()
    with pytest.raises(subprocess.TimeoutExpired):
        peak_memory([sys.executable, '-c', 'import time; time.sleep(60)'], timeout=0.5)
    assert time.monotonic() - begin < 30

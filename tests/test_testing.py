"""zros.testing's helpers that need no router: peak_memory, child_processes."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path, PosixPath

import pytest

import zros.testing
from zros.testing import child_processes, peak_memory

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


class _NoChildrenFiles(PosixPath):
    """/proc as a kernel built without CONFIG_PROC_CHILDREN shows it."""

    def glob(self, pattern: str) -> Iterator[PosixPath]:  # type: ignore[override]  # the one form used
        return iter(()) if pattern.endswith('/children') else super().glob(pattern)


@pytest.mark.parametrize('kernel', ['with task children files', 'without them'])
def test_child_processes_are_found(kernel: str, monkeypatch: pytest.MonkeyPatch) -> None:
    if kernel == 'without them':
        monkeypatch.setattr(zros.testing, 'Path', _NoChildrenFiles)
    code = 'import sys; sys.stdin.read()'  # runs until its stdin closes
    with subprocess.Popen([sys.executable, '-c', code], stdin=subprocess.PIPE) as child:
        assert child.stdin is not None
        assert child.pid in child_processes(os.getpid())
        assert child_processes(child.pid) == []
        child.stdin.close()

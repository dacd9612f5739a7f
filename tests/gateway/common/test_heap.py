"""A gateway process reuses the blocks of the big messages it relays (zros.gateway.common.heap)."""

from __future__ import annotations

import ctypes
import subprocess
import sys
from typing import Any

import pytest

from zros.gateway.common import heap

#: three 1080p rgb8 images allocated and freed on a thread, again and again (a gateway's
#: copies of a message are as many and as large); prints the page faults of one round
ROUNDS = """
import resource, sys, threading
if sys.argv[1] == 'keep':
    from zros.gateway.common.heap import keep_large_blocks
    assert keep_large_blocks()

def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt

def rounds():
    global per_round
    for i in range(25):
        if i == 5:
            start = faults()
        blocks = [b'z' * 6_220_848 for _ in range(3)]
        del blocks
    per_round = (faults() - start) / 20

thread = threading.Thread(target=rounds)
thread.start()
thread.join()
print(per_round)
"""


def _faults_per_round(mode: str) -> float:
    found = subprocess.run(
        [sys.executable, '-c', ROUNDS, mode],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert found.returncode == 0, found.stderr
    return float(found.stdout)


def test_big_blocks_are_reused_instead_of_faulted_in_again() -> None:
    if not _glibc():
        pytest.skip('only glibc malloc has these thresholds')
    # each round touches 4,500 fresh pages without it (the first rounds may fault anyway)
    assert _faults_per_round('default') > 1000
    assert _faults_per_round('keep') < 100


def _glibc() -> bool:
    try:
        ctypes.CDLL(None).gnu_get_libc_version  # noqa: B018  (present in glibc only)
    except (OSError, AttributeError):
        return False
    return sys.platform.startswith('linux')


class _Mallopt:
    """A C function's stand-in (ctypes sets ``argtypes`` and ``restype`` on it)."""

    def __init__(self, answer: int) -> None:
        self.answer = answer
        self.calls: list[tuple[int, int]] = []

    def __call__(self, parameter: int, value: int) -> int:
        self.calls.append((parameter, value))
        return self.answer


class _Libc:
    def __init__(self, answer: int) -> None:
        self.mallopt = _Mallopt(answer)
        self.calls = self.mallopt.calls


def _with_libc(monkeypatch: pytest.MonkeyPatch, libc: Any) -> None:
    monkeypatch.setattr(sys, 'platform', 'linux')
    monkeypatch.setattr(ctypes, 'CDLL', lambda name: libc)


def test_a_malloc_that_refuses_the_thresholds_is_left_alone(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    refusing = _Libc(0)  # musl's mallopt: a stub that returns 0
    _with_libc(monkeypatch, refusing)
    assert heap.keep_large_blocks() is False
    assert len(refusing.calls) == 1  # the trim threshold is not set after a refusal


def test_without_mallopt_nothing_changes(monkeypatch: pytest.MonkeyPatch) -> None:
    _with_libc(monkeypatch, object())  # a C library without mallopt
    assert heap.keep_large_blocks() is False


def test_without_a_c_library_nothing_changes(monkeypatch: pytest.MonkeyPatch) -> None:
    def missing(name: Any) -> Any:
        raise OSError('no C library')

    monkeypatch.setattr(sys, 'platform', 'linux')
    monkeypatch.setattr(ctypes, 'CDLL', missing)
    assert heap.keep_large_blocks() is False


def test_other_systems_are_left_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    accepting = _Libc(1)
    _with_libc(monkeypatch, accepting)
    monkeypatch.setattr(sys, 'platform', 'darwin')
    assert heap.keep_large_blocks() is False
    assert accepting.calls == []


def test_glibc_gets_both_thresholds(monkeypatch: pytest.MonkeyPatch) -> None:
    accepting = _Libc(1)
    _with_libc(monkeypatch, accepting)
    assert heap.keep_large_blocks() is True
    assert accepting.calls == [(-3, heap.MMAP_THRESHOLD), (-1, heap.TRIM_THRESHOLD)]

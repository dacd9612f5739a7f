"""Shared test configuration."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

#: Real recordings live beside the repository, never inside it.
TESTDATA = Path(__file__).resolve().parent.parent.parent / 'shared' / 'testdata'


def pytest_configure(config: pytest.Config) -> None:
    """A shell that starts a job in the background (``cmd &``, no job control) has it ignore
    Ctrl-C, and an ignored signal stays ignored in every process it starts: the commands and
    scripts the tests interrupt with SIGINT would never see it. The tests' processes get the
    usual SIGINT instead, however the test run was started."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture
def testdata() -> Path:
    """The shared recordings folder; tests using it skip where it is absent."""
    if not TESTDATA.is_dir():
        pytest.skip(f'recordings folder {TESTDATA} is absent (it is not part of a clone)')
    return TESTDATA

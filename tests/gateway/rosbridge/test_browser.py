"""The roslibjs page of ``examples/rosbridge_web`` in headless Chromium (Debian's
``chromium-headless-shell`` or ``chromium``), served from a folder, against ``zros rosbridge``:
the page says hello, shows /chatter and echoes it back. Skips where no Chromium is installed
(fails instead with ZROS_TEST_BROWSER_REQUIRED=1, as in CI, which installs it)."""

from __future__ import annotations

import functools
import http.server
import os
import shutil
import signal
import subprocess
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

import zros
from tests.gateway.node_process import NODE_DIR
from tests.gateway.rosbridge.roslib_client import require_roslib
from zros.testing import wait_for

Make = Callable[..., Any]
TIMEOUT = 60.0
EXAMPLE = Path(__file__).parents[3] / 'examples' / 'rosbridge_web'
BROWSERS = ('chromium-headless-shell', 'chromium')


def browser() -> str:
    for name in BROWSERS:
        found = shutil.which(name)
        if found is not None:
            return found
    reason = (
        f'no headless Chromium ({" or ".join(BROWSERS)}; apt-get install chromium-headless-shell)'
    )
    if os.environ.get('ZROS_TEST_BROWSER_REQUIRED'):
        pytest.fail(reason)
    pytest.skip(reason)


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: Any) -> None:
        """No access log in the test output."""


@pytest.fixture
def page_folder(tmp_path: Path) -> Iterator[str]:
    """The example served from a folder on a loopback HTTP server (its node_modules are the
    test clients', which hold the same roslib); the page's base URL."""
    require_roslib()
    folder = tmp_path / 'site'
    folder.mkdir()
    shutil.copy(EXAMPLE / 'index.html', folder / 'index.html')
    (folder / 'node_modules').symlink_to(NODE_DIR / 'node_modules')
    handler = functools.partial(_Quiet, directory=str(folder))
    server = http.server.ThreadingHTTPServer(('127.0.0.1', 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f'http://127.0.0.1:{server.server_address[1]}/index.html'
    server.shutdown()
    thread.join(5)


@pytest.fixture
def chromium(tmp_path: Path) -> Iterator[Callable[[str], subprocess.Popen[bytes]]]:
    executable = browser()
    started: list[subprocess.Popen[bytes]] = []

    def open_page(url: str) -> subprocess.Popen[bytes]:
        args = [
            executable, '--headless', '--no-sandbox', '--disable-gpu',
            '--disable-background-networking', '--disable-component-update', '--disable-sync',
            '--no-first-run', f'--user-data-dir={tmp_path / "profile"}', url,
        ]  # fmt: skip
        log = (tmp_path / 'chromium.log').open('wb')
        process = subprocess.Popen(args, stdout=log, stderr=log, start_new_session=True)
        started.append(process)
        return process

    yield open_page
    for process in started:  # the browser and the helpers it started, in its own group
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(10)


def test_the_example_page_runs_in_a_browser(
    rosbridge: Make, zros_node: Make, page_folder: str, chromium: Make
) -> None:
    gateway = rosbridge()
    robot = zros_node('robot')
    hello = robot.create_subscription('std_msgs/msg/String', '/web_hello')
    echo = robot.create_subscription('std_msgs/msg/String', '/web_echo')
    chatter = robot.create_publisher('std_msgs/msg/String', '/chatter')
    chromium(f'{page_folder}?url={gateway.url}')
    greeting = hello.wait_for_message(TIMEOUT)
    assert greeting is not None and greeting.data == 'hello from a browser'
    sent = iter(range(10_000))

    def echoed() -> bool:  # the page's subscription may need a moment: say it until heard
        chatter.write(zros.Message('std_msgs/msg/String', data=f'hi {next(sent)}'))
        return echo.has_new_message()

    assert wait_for(echoed, TIMEOUT)
    assert echo.read_message().data.startswith('echo: hi ')

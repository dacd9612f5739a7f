"""The gateway folders: each gateway package names its server and classes (loaded on first use,
so one module of a folder loads without the server), and unknown names are refused."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import zros.foxglove
import zros.rosbridge
from zros.gateway.foxglove import bag_server

ROOT = Path(__file__).resolve().parents[2]


def test_the_gateway_packages_name_what_their_doors_export() -> None:
    from zros.gateway.foxglove import BagGateway, FoxgloveGateway, ServerOptions, serve
    from zros.gateway.rosbridge import RosbridgeGateway
    from zros.gateway.rosbridge import serve as serve_rosbridge

    assert (serve, FoxgloveGateway, ServerOptions) == (
        zros.foxglove.serve,
        zros.foxglove.FoxgloveGateway,
        zros.foxglove.ServerOptions,
    )
    assert BagGateway is bag_server.BagGateway
    assert (serve_rosbridge, RosbridgeGateway) == (
        zros.rosbridge.serve,
        zros.rosbridge.RosbridgeGateway,
    )


@pytest.mark.parametrize('package', ['zros.gateway.foxglove', 'zros.gateway.rosbridge'])
def test_an_unknown_name_of_a_gateway_package_is_an_attribute_error(package: str) -> None:
    module = sys.modules.get(package) or __import__(package, fromlist=['_'])
    with pytest.raises(AttributeError, match=f"module '{package}' has no attribute 'Gateway'"):
        _ = module.Gateway


def test_the_foxglove_front_loads_without_the_server() -> None:
    code = (
        'import sys, zros.gateway.foxglove.front, zros.gateway.rosbridge.frames\n'
        "print(sorted(m for m in sys.modules if m.startswith('zros.gateway') and 'server' in m))"
    )
    env = {
        **os.environ,
        'PYTHONPATH': os.pathsep.join([str(ROOT), os.environ.get('PYTHONPATH', '')]),
    }
    found = subprocess.run(
        [sys.executable, '-c', code],
        capture_output=True,
        text=True,
        env=env,
        check=True,
        timeout=60,
    )
    assert found.stdout.strip() == '[]'

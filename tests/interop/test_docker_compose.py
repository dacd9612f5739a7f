"""``docker/compose.yml`` is valid and runs the interop suite against the real bridge.

With the Docker compose plugin, ``docker compose config`` validates the file; without it (as
here) PyYAML parses it and the checks below stand in for the schema.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

from tests.interop import rig

DOCKER = Path(__file__).resolve().parents[2] / 'docker'
COMPOSE = DOCKER / 'compose.yml'

#: the service keys compose.yml may use (a subset of the Compose specification)
SERVICE_KEYS = {
    'image',
    'command',
    'environment',
    'volumes',
    'working_dir',
    'depends_on',
    'healthcheck',
    'ports',
    'network_mode',
}


def compose_plugin() -> bool:
    if shutil.which('docker') is None:
        return False
    result = subprocess.run(['docker', 'compose', 'version'], capture_output=True, check=False)
    return result.returncode == 0


@pytest.fixture(scope='module')
def compose() -> dict[str, Any]:
    yaml = pytest.importorskip('yaml')
    with COMPOSE.open() as stream:
        return yaml.safe_load(stream)  # type: ignore[no-any-return]


@pytest.mark.skipif(not compose_plugin(), reason='the docker compose plugin is not installed')
def test_docker_compose_config() -> None:
    result = subprocess.run(
        ['docker', 'compose', '-f', str(COMPOSE), 'config', '--quiet'],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr


def test_services_and_images(compose: dict[str, Any]) -> None:
    services = compose['services']
    assert set(services) == {'ros', 'bridge', 'zros'}
    for name, service in services.items():
        assert set(service) <= SERVICE_KEYS, (
            f'{name}: unexpected keys {set(service) - SERVICE_KEYS}'
        )
        assert isinstance(service['image'], str)
    assert services['ros']['image'] == 'ros:jazzy'
    # pinned to a 1.x release (the spec's TL protocol depends on the version)
    assert re.fullmatch(r'eclipse/zenoh-bridge-ros2dds:1\.\d+\.\d+', services['bridge']['image'])
    assert services['zros']['image'].startswith('python:3.11')


def _command(service: dict[str, Any]) -> str:
    command = service['command']
    return command if isinstance(command, str) else ' '.join(command)


def test_bridge_listens_where_zros_connects(compose: dict[str, Any]) -> None:
    services = compose['services']
    bridge = _command(services['bridge'])
    assert '--listen tcp/0.0.0.0:7447' in bridge
    assert '--no-multicast-scouting' in bridge
    assert '--namespace ${ZROS_BRIDGE_NAMESPACE:-/}' in bridge
    env = services['zros']['environment']
    assert env[rig.ENV_BRIDGE] == 'tcp/bridge:7447'
    assert env[rig.ENV_BRIDGE_NAMESPACE] == '${ZROS_BRIDGE_NAMESPACE:-/}'
    # the ROS side and the bridge share a DDS domain
    assert (
        services['ros']['environment']['ROS_DOMAIN_ID']
        == (services['bridge']['environment']['ROS_DOMAIN_ID'])
    )


def test_zros_runs_the_interop_suite(compose: dict[str, Any]) -> None:
    zros = compose['services']['zros']
    command = _command(zros)
    assert "pip install -q -e '.[test,interop]'" in command
    assert 'pytest -p no:cacheprovider tests/interop' in command
    assert '..:/zros' in zros['volumes']
    assert zros['working_dir'] == '/zros'
    assert zros['depends_on']['ros']['condition'] == 'service_healthy'
    assert set(zros['depends_on']) == {'ros', 'bridge'}


def test_ros_serves_workers_where_the_suite_looks(compose: dict[str, Any]) -> None:
    services = compose['services']
    address = services['zros']['environment'][rig.ENV_WORKER]
    scheme, _, where = address.partition(':')
    host, _, port = where.rpartition(':')
    assert (scheme, host) == ('tcp', 'ros')
    ros = _command(services['ros'])
    assert f'tests/interop/ros_worker.py --serve tcp:0.0.0.0:{port}' in ros
    assert (DOCKER.parent / 'tests' / 'interop' / 'ros_worker.py').is_file()
    assert services['ros']['environment']['RMW_IMPLEMENTATION'] == 'rmw_cyclonedds_cpp'
    assert port in ' '.join(services['ros']['healthcheck']['test'])


def test_readme_explains_the_run() -> None:
    readme = (DOCKER / 'README.md').read_text()
    assert 'docker compose -f docker/compose.yml up' in readme
    for variable in (rig.ENV_BRIDGE, rig.ENV_WORKER, rig.ENV_BRIDGE_NAMESPACE):
        assert variable in readme

"""The package as a release ships it: an sdist and a wheel, built without warnings, that
install into a fresh virtual environment outside the checkout and run ``zros demo`` there."""

from __future__ import annotations

import importlib
import importlib.util
import os
import re
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from pathlib import Path

import pytest

from tests.demo.test_demo import check_report

ROOT = Path(__file__).resolve().parent.parent
DISTRIBUTION = 'zros-client'  # `zros` on PyPI is another project
TIMEOUT = 300


def run(command: list[str], cwd: Path, log: Path) -> str:
    """Run ``command``; its output goes to ``log`` too, and a failure shows it."""
    env = {k: v for k, v in os.environ.items() if k not in ('PYTHONPATH', 'VIRTUAL_ENV')}
    result = subprocess.run(
        command,
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        check=False,
    )
    output = result.stdout + result.stderr
    with log.open('a') as file:
        file.write(f'$ {" ".join(command)}\n{output}\n')
    assert result.returncode == 0, output
    return output


@pytest.fixture(scope='module')
def dist(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sdist and the wheel built from it, as ``python -m build`` makes them."""
    if importlib.util.find_spec('build') is None:
        pytest.skip("the 'build' package is not installed (it comes with the test extra)")
    folder = tmp_path_factory.mktemp('dist')
    # without isolation: the build backend is the test environment's setuptools, so no
    # download is needed; --no-isolation still checks it satisfies [build-system] requires
    output = run(
        [sys.executable, '-m', 'build', '--no-isolation', '--outdir', str(folder), str(ROOT)],
        cwd=folder,
        log=folder / 'build.log',
    )
    assert 'Successfully built' in output
    assert 'WARNING' not in output and 'Deprecat' not in output, output
    return folder


def test_the_sdist_and_wheel_carry_the_package_data_and_license(dist: Path) -> None:
    (wheel,) = dist.glob('zros_client-*-py3-none-any.whl')
    (sdist,) = dist.glob('zros_client-*.tar.gz')
    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
        info = next(n for n in names if n.endswith('.dist-info/METADATA'))
        metadata = archive.read(info).decode()
    assert {'zros/py.typed', 'zros/demo/msg/Linearization.msg', 'zros/cli/main.py'} <= names
    assert not any(n.startswith(('tests/', 'examples/', 'docs/')) for n in names)
    assert f'Name: {DISTRIBUTION}\n' in metadata
    assert 'License-Expression: Apache-2.0\n' in metadata
    assert 'License-File: LICENSE\n' in metadata
    assert any(n.endswith('.dist-info/licenses/LICENSE') for n in names)
    with tarfile.open(sdist) as archive:
        members = {Path(*Path(m).parts[1:]).as_posix() for m in archive.getnames()}
    assert {'LICENSE', 'README.md', 'pyproject.toml', 'zros/demo/msg/Linearization.msg'} <= members


def test_the_wheel_installs_in_a_fresh_venv_and_runs_the_demo(dist: Path, tmp_path: Path) -> None:
    (wheel,) = dist.glob('zros_client-*-py3-none-any.whl')
    log = tmp_path / 'install.log'
    venv = tmp_path / 'venv'
    run([sys.executable, '-m', 'venv', str(venv)], cwd=tmp_path, log=log)
    python = venv / 'bin' / 'python'
    # the dependencies (zenoh, numpy, matplotlib...) come from this test environment, as with
    # --system-site-packages, so that the test needs no network; zros itself only from the wheel
    site = venv / 'lib' / f'python{sys.version_info.major}.{sys.version_info.minor}'
    paths = dict.fromkeys([sysconfig.get_path('purelib'), sysconfig.get_path('platlib')])
    (site / 'site-packages' / 'test-dependencies.pth').write_text('\n'.join(paths) + '\n')
    run(
        [str(python), '-m', 'pip', 'install', '--no-deps', '--no-index', '--ignore-installed',
         str(wheel)],
        cwd=tmp_path,
        log=log,
    )  # fmt: skip
    where = run(
        [str(python), '-c', 'import zros, zros.cli.main; print(zros.__file__)'],
        cwd=tmp_path,
        log=log,
    )
    assert Path(where.strip()).is_relative_to(venv), where
    zros_command = venv / 'bin' / 'zros'
    assert zros_command.exists()
    output = run([str(zros_command), 'demo', '--output', 'out'], cwd=tmp_path, log=log)
    check_report(output, tmp_path / 'out')


def test_no_install_hint_names_the_other_zros_project() -> None:
    # `zros` on PyPI is somebody else's: every hint names zros-client (zros.version.install_hint)
    hint = re.compile(r'(?<![\w-])zros\[[a-z]')
    places = [*ROOT.joinpath('zros').rglob('*.py'), *ROOT.joinpath('docs').rglob('*.md')]
    places += [ROOT / 'README.md', *ROOT.joinpath('examples').glob('*.py')]
    found = [
        f'{path.relative_to(ROOT)}:{number}'
        for path in places
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if hint.search(line)
    ]
    assert found == []


@pytest.mark.parametrize(
    ('missing', 'call', 'extra'),
    [
        ('foxglove', 'zros.gateway.foxglove.sdk:import_sdk', 'foxglove'),
        ('websockets', 'zros.gateway.rosbridge.server:import_websockets', 'rosbridge'),
        ('cryptography', 'zros.transport.pki:_crypto', 'tls'),
    ],
)
def test_a_missing_extra_names_what_to_install(
    missing: str, call: str, extra: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    module_name, function = call.split(':')
    module = importlib.import_module(module_name)
    for name in list(sys.modules):
        if name == missing or name.startswith(missing + '.'):
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, missing, None)  # import fails as when not installed
    with pytest.raises(Exception, match=r'pip install') as raised:
        getattr(module, function)()
    text = str(raised.value)
    assert f"pip install 'zros-client[{extra}]'" in text
    assert f"pip install '.[{extra}]'" in text

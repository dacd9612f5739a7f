"""Files for ``package://`` and ``file://`` URIs (a URDF's meshes), from folders the user names.

An asset folder is a folder of packages (``<dir>/<pkg>/meshes/base.stl``), an install prefix
(``<dir>/share/<pkg>/...``, as colcon installs), or one package's own folder (its name, or its
``package.xml``, names the package). Nothing outside those folders is ever read: a package
name must be a ROS package name, and the file a URI names must lie inside an asset folder once
``..`` and symbolic links are resolved (a link leading out, even a package folder's, is refused).
"""

from __future__ import annotations

import logging
import os
import re
import urllib.parse
from collections.abc import Iterable
from pathlib import Path

from zros.gateway.common.errors import GatewayError

_log = logging.getLogger('zros.gateway')

#: the largest file served (the SDK sends an asset in one message)
MAX_ASSET_BYTES = 256 * 1024 * 1024
_PACKAGE_NAME = re.compile(r'<name>\s*([A-Za-z0-9_]+)\s*</name>')
#: what a ROS package may be called (REP 144, with the capitals and dashes found in the wild)
_VALID_PACKAGE = re.compile(r'[A-Za-z][A-Za-z0-9_-]*')


def _package_name(folder: Path) -> str:
    """The name a package folder's ``package.xml`` gives (else the folder's name)."""
    try:
        match = _PACKAGE_NAME.search((folder / 'package.xml').read_text(errors='replace'))
    except OSError:
        match = None
    return match.group(1) if match else folder.name


class Assets:
    """Resolves asset URIs inside ``folders`` and reads them."""

    def __init__(self, folders: Iterable[str | os.PathLike[str]]) -> None:
        self.folders: list[Path] = []
        for folder in folders:
            path = Path(folder).expanduser()
            if not path.is_dir():
                raise GatewayError(f'the asset folder {folder} does not exist')
            self.folders.append(path.resolve())

    def _package_roots(self, package: str) -> list[Path]:
        roots = []
        for folder in self.folders:
            roots += [folder / package, folder / 'share' / package]
            if _package_name(folder) == package:
                roots.append(folder)
        return [root.resolve() for root in roots if root.is_dir()]

    def resolve(self, uri: str) -> Path:
        """The file a URI names; GatewayError when it is refused or absent."""
        parsed = urllib.parse.urlparse(uri)
        if parsed.scheme == 'package':
            package = parsed.netloc
            if not _VALID_PACKAGE.fullmatch(package):
                raise GatewayError(f'{uri}: {package!r} is not a package name')
            relative = urllib.parse.unquote(parsed.path).lstrip('/')
            roots = self._package_roots(package)
            if not roots:
                raise GatewayError(f'{uri}: no package {package!r} in the asset folders')
        elif parsed.scheme == 'file':
            path = Path(urllib.parse.unquote(parsed.path))
            roots = [f for f in self.folders if path.resolve().is_relative_to(f)]
            if not roots or not path.is_absolute():
                raise GatewayError(f'{uri}: only files inside the asset folders are served')
            relative = str(path.resolve().relative_to(roots[0]))
        else:
            raise GatewayError(f'{uri}: only package:// and file:// URIs are served')
        parts = Path(relative).parts
        if not relative or '..' in parts or Path(relative).is_absolute():
            raise GatewayError(f'{uri}: the path must stay inside the package')
        for root in roots:
            candidate = (root / relative).resolve()
            if not any(candidate.is_relative_to(folder) for folder in self.folders):
                raise GatewayError(f'{uri}: the path leads outside the asset folders')
            if candidate.is_file():
                return candidate
        raise GatewayError(f'{uri}: no such file in the asset folders')

    def fetch(self, uri: str) -> bytes:
        """The bytes of the file a URI names (GatewayError says why not)."""
        path = self.resolve(uri)
        size = path.stat().st_size
        if size > MAX_ASSET_BYTES:
            raise GatewayError(f'{uri}: {size} bytes is more than the {MAX_ASSET_BYTES} served')
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise GatewayError(f'{uri}: cannot read it: {exc.strerror}') from None
        _log.info('served %s (%d bytes)', uri, len(data))
        return data

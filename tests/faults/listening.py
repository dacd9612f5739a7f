"""What a process listens on, read from /proc (Linux): the sockets in LISTEN state it owns."""

from __future__ import annotations

import ipaddress
import os
import socket
from pathlib import Path

_LISTEN = '0A'


def _address(text: str, family: int) -> str:
    host, port = text.split(':')
    raw = bytes.fromhex(host)
    # /proc prints each 32-bit word in host order (little-endian here)
    packed = b''.join(raw[i : i + 4][::-1] for i in range(0, len(raw), 4))
    address = ipaddress.ip_address(socket.inet_ntop(family, packed))
    shown = f'[{address}]' if address.version == 6 else str(address)
    return f'{shown}:{int(port, 16)}'


def listening(pid: int | None = None) -> set[str]:
    """``host:port`` of every TCP socket the process listens on."""
    pid = os.getpid() if pid is None else pid
    inodes = set()
    for fd in Path(f'/proc/{pid}/fd').iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith('socket:['):
            inodes.add(target[8:-1])
    found = set()
    for table, family in (('tcp', socket.AF_INET), ('tcp6', socket.AF_INET6)):
        for line in Path(f'/proc/net/{table}').read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == _LISTEN and fields[9] in inodes:
                found.add(_address(fields[1], family))
    return found


def is_loopback(host_port: str) -> bool:
    """Whether ``host:port`` (as :func:`listening` gives it) is reachable from this host only."""
    host = host_port.rpartition(':')[0].strip('[]')
    return ipaddress.ip_address(host).is_loopback

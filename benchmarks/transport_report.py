"""The tables of ``benchmarks/transport.py``: every row with its ratio to raw Zenoh, and the goals
of issue 17 (met or missed)."""

from __future__ import annotations

from typing import Any

from transport_roles import BEFORE, twin

Rows = dict[str, dict[str, Any]]  #: 'row/impl' -> the median run
#: the width of the rows' labels, and of the tables' first heading
LABEL = 40
HEAD = LABEL + 4


def with_before(names: dict[str, str]) -> dict[str, str]:
    """``names`` (competitor -> label), each followed by its twin run from the code before."""
    return {
        key: label
        for impl, name in names.items()
        for key, label in ((impl, name), (impl + BEFORE, f'  {name} (before)'))
    }


#: the String row's competitors
STRING_NAMES = {
    'zenoh': 'raw zenoh, bytes only',
    'zenoh_decode': 'raw zenoh + zros decode',
    'zenoh_codec': 'raw + decode, publisher encodes',
    'zenoh_rmw': 'raw + attachment + decode',
    'zros': 'zros callback (bridge)',
    'zros_bytes': 'zros callback, bytes only',
    'zros_rmw': 'zros callback (rmw_zenoh)',
    'zros_poll': 'zros spin_once + take',
    'zros_now': 'zros immediate callbacks',
}
#: the String row's goals: (competitor, reference, what, the least ratio)
STRING_GOALS = [
    ('zros', 'zenoh_decode', 'zros callback / raw + decode', 0.85),
    ('zros', 'zenoh', 'zros callback / raw bytes', 0.75),
    ('zros_poll', 'zenoh', 'zros spin_once+take / raw bytes', 0.75),
    ('zros_now', 'zenoh_decode', 'zros immediate / raw + decode', 0.85),
    ('zros_rmw', 'zros', 'rmw_zenoh wire / bridge wire', 0.95),
]
#: the round trip's competitors
RTT_NAMES = {
    'zenoh': 'raw zenoh',
    'zros': 'zros',
    'zros_rmw': 'zros rmw_zenoh',
    'zros_now': 'zros immediate',
}


def _cpu_per_message(row: dict[str, Any]) -> float:
    """Microseconds of the subscriber's CPU per message, from the first to the last."""
    return float(row['cpu']) / max(row['received'] - 1, 1) * 1e6


def _mbs(row: dict[str, Any]) -> float:
    return float(row['rate'] * row['size'] / 1e6)


def _us(row: dict[str, Any], key: str) -> float:
    return float(row[key]) * 1e6


def _size(size: int) -> str:
    for unit, scale in (('MB', 1_000_000), ('KB', 1_000)):
        if size >= scale:
            return f'{size // scale} {unit}'
    return f'{size} B'


def _print_strings(rows: Rows, goals: list[tuple[str, float, str, bool]]) -> None:
    raw, decoded = rows.get('string/zenoh'), rows.get('string/zenoh_decode')
    if not any(key.startswith('string/') for key in rows):
        return
    print(
        f'{"(a) std_msgs/String msgs/s":{HEAD}} {"msgs/s":>10} {"/ bytes":>8} {"/ decode":>8}'
        f' {"sub CPU us":>10}  runs'
    )
    for impl, name in with_before(STRING_NAMES).items():
        found = rows.get(f'string/{impl}')
        if found is None:
            continue
        rate = found['rate']
        over_raw = f'{rate / raw["rate"]:8.2f}' if raw else ' ' * 8
        over_decoded = f'{rate / decoded["rate"]:8.2f}' if decoded else ' ' * 8
        cpu = _cpu_per_message(found)
        runs = ' '.join(f'{r / 1000:.0f}k' for r in found['runs'])
        print(f'    {name:{LABEL}} {rate:>10,.0f} {over_raw} {over_decoded} {cpu:>10.2f}  {runs}')
    print(
        "    sub CPU us: the subscriber process's CPU per message (all its threads), steadier "
        'than the rates here'
    )
    for ours, theirs, text, target in STRING_GOALS:
        found, reference = rows.get(f'string/{ours}'), rows.get(f'string/{theirs}')
        if found and reference:
            ratio = found['rate'] / reference['rate']
            goals.append((f'String, {text}', ratio, f'>= {target:.2f}', ratio >= target))
    attached = rows.get('string/zenoh_rmw')
    if attached and decoded:
        print(
            "    what rmw_zenoh's attachment costs raw zenoh: raw + attachment + decode / "
            f'raw + decode {attached["rate"] / decoded["rate"]:.2f}'
        )


def _print_images(rows: Rows, goals: list[tuple[str, float, str, bool]]) -> None:
    raw = rows.get('image/zenoh')
    if raw is None:
        return
    print(f'{"(b) Image 1080p rgb8 MB/s":{HEAD}} {"MB/s":>10} {"/ raw":>8}')
    names = {'zenoh': 'raw zenoh', 'zros': 'zros', 'zros_rmw': 'zros rmw_zenoh'}
    for impl, name in with_before(names).items():
        found = rows.get(f'image/{impl}')
        if found is not None:
            print(f'    {name:{LABEL}} {_mbs(found):>10,.0f} {_mbs(found) / _mbs(raw):8.2f}')
    zros = rows.get('image/zros')
    if zros:
        ratio = _mbs(zros) / _mbs(raw)
        goals.append(('Image 1080p MB/s, zros / raw', ratio, '>= 0.80', ratio >= 0.8))


def _print_sizes(rows: Rows, goals: list[tuple[str, float, str, bool]]) -> None:
    sizes = sorted(int(key[5:].split('/')[0]) for key in rows if key.startswith('bytes'))
    sizes = sorted(set(sizes))
    if not sizes:
        return
    print(
        f'(c) uint8[]   {"raw msgs/s":>12} {"raw MB/s":>9} {"zros msgs/s":>12} {"zros MB/s":>9}'
        f' {"zros/raw":>9} {"raw+dec/raw":>11} {"zros/raw+dec":>12} {"raw+codec/raw":>13}'
    )
    worst: tuple[float, int] | None = None
    for size in sizes:
        raw, zros = rows.get(f'bytes{size}/zenoh'), rows.get(f'bytes{size}/zros')
        if raw is None or zros is None:
            continue
        ratio = zros['rate'] / raw['rate']
        worst = min(worst or (ratio, size), (ratio, size))
        decoded = rows.get(f'bytes{size}/zenoh_decode')
        floor = f'{decoded["rate"] / raw["rate"]:>11.2f}' if decoded else ' ' * 11
        over_floor = f'{zros["rate"] / decoded["rate"]:>12.2f}' if decoded else ' ' * 12
        coded = rows.get(f'bytes{size}/zenoh_codec')
        codec_floor = f'{coded["rate"] / raw["rate"]:>13.2f}' if coded else ''
        print(
            f'    {_size(size):>7} {raw["rate"]:>12,.0f} {_mbs(raw):>9,.1f} {zros["rate"]:>12,.0f}'
            f' {_mbs(zros):>9,.1f} {ratio:>9.2f} {floor} {over_floor} {codec_floor}'
        )
        earlier = rows.get(f'bytes{size}/zros{BEFORE}')
        if earlier is not None:
            print(
                f'    {"(before)":>7} {"":>12} {"":>9} {earlier["rate"]:>12,.0f}'
                f' {_mbs(earlier):>9,.1f} {earlier["rate"] / raw["rate"]:>9.2f}'
            )
    if worst is not None:
        text = f'uint8[] 10 B-10 MB, zros / raw (worst: {_size(worst[1])})'
        goals.append((text, worst[0], '>= 0.75', worst[0] >= 0.75))


def _print_round_trips(rows: Rows, goals: list[tuple[str, float, str, bool]]) -> None:
    if 'rtt/zenoh' not in rows:
        return
    print(f'{"(d) Float64 round trip, us":{HEAD}} {"median":>10} {"p99":>8} {"- raw":>8}')
    for row, where in (('rtt', 'router'), ('rtt_peer', 'peer to peer')):
        raw = rows[f'{row}/zenoh']
        names = {
            f'{row}/{impl}': f'{name}, {where}' for impl, name in with_before(RTT_NAMES).items()
        }
        _print_times(rows, names, raw)
        for impl, name in (('zros', 'zros'), ('zros_now', 'zros immediate')):
            zros = rows.get(f'{row}/{impl}')
            if zros is None:
                continue
            over = _us(zros, 'median') - _us(raw, 'median')
            goals.append((f'RTT median, {where}: {name} - raw (us)', over, '<= +30', over <= 30))
            if row == 'rtt':
                ratio = zros['p99'] / raw['p99']
                goals.append((f'RTT p99, {where}: {name} / raw', ratio, '<= 1.00', ratio <= 1.0))


#: row e: what each (echo, ping) pair shows
SPLIT_NAMES = {
    'zenoh:zenoh': 'raw both (row d)',
    'zenoh:zenoh_fifo': 'raw, ping waits in Rust',
    'zenoh_spin:zenoh': 'raw, echo on a spinning thread',
    'zenoh_dec:zenoh': 'raw echo, decodes + encodes',
    'zenoh_spin_dec:zenoh': 'raw spinning echo, decodes',
    'zenoh_relay_dec:zenoh': '  the same, through a FIFO and a thread',
    'zros:zenoh': 'zros echo (spin)',
    'zenoh_fifo_dec:zenoh': 'raw echo decoding, FIFO and a thread',
    'zros_now:zenoh': 'zros echo (immediate)',
    'zenoh:zenoh_dec': 'raw ping, encodes + decodes',
    'zenoh:zenoh_relay_dec': '  the same, through a FIFO and a thread',
    'zenoh:zros': 'zros ping',
    'zros_now:zros': 'zros both (immediate echo)',
}


def _print_times(rows: Rows, names: dict[str, str], base: dict[str, Any]) -> None:
    """A line per round-trip row of ``names`` measured: median, p99, median - ``base``'s."""
    for key, label in names.items():
        found = rows.get(key)
        if found is None:
            continue
        over = _us(found, 'median') - _us(base, 'median')
        print(
            f'    {label:{LABEL}} {_us(found, "median"):>10,.0f} {_us(found, "p99"):>8,.0f} {over:>+8,.0f}'
        )


def _print_split(rows: Rows) -> None:
    base = rows.get('split/zenoh:zenoh')
    if base is None:
        return
    print(f'{"(e) round trip split, router, us":{HEAD}} {"median":>10} {"p99":>8} {"- raw":>8}')
    names = {}
    for pair, name in SPLIT_NAMES.items():
        names[f'split/{pair}'] = name
        echo, ping = pair.split(':')
        if 'zros' in pair:
            names[f'split/{twin(echo)}:{twin(ping)}'] = f'  {name} (before)'
    _print_times(rows, names, base)


def report(rows: Rows, rclpy: dict[str, dict[str, Any]] | None = None) -> None:
    """Print every row measured, then the goals."""
    goals: list[tuple[str, float, str, bool]] = []
    print()
    _print_strings(rows, goals)
    _print_images(rows, goals)
    _print_sizes(rows, goals)
    _print_round_trips(rows, goals)
    _print_split(rows)
    if rclpy is not None:
        print(
            f'rclpy over Fast DDS: String {rclpy["string"]["rate"]:,.0f} msgs/s, Image '
            f'{_mbs(rclpy["image"]):,.0f} MB/s, RTT peer to peer median '
            f'{_us(rclpy["rtt"], "median"):,.0f} us, p99 {_us(rclpy["rtt"], "p99"):,.0f} us'
        )
        if 'string/zros' in rows and 'rtt_peer/zros' in rows:
            ours = rows['string/zros']['rate'] / rclpy['string']['rate']
            goals.append(('zros beats rclpy on String msgs/s', ours, '> 1', ours > 1))
            ours = rows['rtt_peer/zros']['median'] / rclpy['rtt']['median']
            goals.append(('zros beats rclpy on RTT (zros / rclpy)', ours, '< 1', ours < 1))
    print()
    print(f'    {"goal":50} {"found":>8} {"target":>8}')
    for text, value, target, met in goals:
        print(f'    {text:50} {value:>8.2f} {target:>8}  {"met" if met else "MISSED"}')
    _print_floors(rows)
    lost = {key: row['lost'] for key, row in rows.items() if row.get('lost')}
    print(f'  messages lost: {lost or "none"} (none may be)')


def _floors(rows: Rows) -> list[tuple[str, float, str, bool]]:
    """The goals as raw zenoh-python meets them doing the least zros must (decode, carry the
    attachment, hand over to a spinning thread), where the run measured that."""
    floors: list[tuple[str, float, str, bool]] = []
    raw, decoded = rows.get('string/zenoh'), rows.get('string/zenoh_decode')
    if raw and decoded:
        ratio = decoded['rate'] / raw['rate']
        floors.append(('String, raw + decode / raw bytes', ratio, '>= 0.75', ratio >= 0.75))
    attached = rows.get('string/zenoh_rmw')
    if attached and decoded:
        ratio = attached['rate'] / decoded['rate']
        floors.append(
            ('String, raw + attachment / raw (both decode)', ratio, '>= 0.95', ratio >= 0.95)
        )
    coded = rows.get('string/zenoh_codec')
    if raw and coded:
        ratio = coded['rate'] / raw['rate']
        floors.append(
            ('String, raw + encode + decode / raw bytes', ratio, '>= 0.75', ratio >= 0.75)
        )
    for floor, what in (('zenoh_decode', 'raw + decode'), ('zenoh_codec', 'raw + codec')):
        sizes = [
            (rows[f'{key}/{floor}']['rate'] / rows[f'{key}/zenoh']['rate'], key[5:])
            for key in {k.split('/')[0] for k in rows if k.startswith('bytes')}
            if f'{key}/{floor}' in rows and f'{key}/zenoh' in rows
        ]
        if sizes:
            ratio, size = min(sizes)
            text = f'uint8[], {what} / raw (worst: {_size(int(size))})'
            floors.append((text, ratio, '>= 0.75', ratio >= 0.75))
    base = rows.get('split/zenoh:zenoh')
    pairs = (  # (what, echo, ping): zros's structure is a FIFO channel and a thread of its own
        ('spinning echo + ping decoding', 'zenoh_spin_dec', 'zenoh_dec'),
        ('immediate echo + ping decoding', 'zenoh_dec', 'zenoh_dec'),
        ("the same in zros's structure, spinning", 'zenoh_relay_dec', 'zenoh_relay_dec'),
        ("the same in zros's structure, immediate", 'zenoh_fifo_dec', 'zenoh_relay_dec'),
    )
    for how, echo, ping in pairs:
        found, pinged = rows.get(f'split/{echo}:zenoh'), rows.get(f'split/zenoh:{ping}')
        if base and found and pinged:
            raw_us = _us(base, 'median')
            over = (_us(found, 'median') - raw_us) + (_us(pinged, 'median') - raw_us)
            floors.append((f'RTT router, {how}: - raw (us)', over, '<= +30', over <= 30))
    return floors


def _print_floors(rows: Rows) -> None:
    floors = _floors(rows)
    if not floors:
        return
    print()
    print(f'    {"the same goals for raw zenoh-python doing the least zros must":56} {"found":>8}')
    for text, value, target, met in floors:
        verdict = 'within reach' if met else 'out of reach for raw zenoh-python itself here'
        print(f'    {text:56} {value:>8.2f} {target:>8}  {verdict}')

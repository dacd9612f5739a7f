"""The version of zros, and the wording its messages share (a leaf module: any part of zros
may import it)."""

__version__ = '0.1.0'
#: the name zros is installed by (``zros`` on PyPI is another project)
DISTRIBUTION = 'zros-client'


def install_hint(extra: str) -> str:
    """What to run to get one of zros's extras (``tls``, ``foxglove``, ``rosbridge``...)."""
    return (
        f"pip install '{DISTRIBUTION}[{extra}]' (in a checkout of zros: pip install '.[{extra}]')"
    )


def counted(number: int, noun: str) -> str:
    """``1 topic``, ``2 topics``: a count and its noun, singular for one."""
    return f'{number} {noun if number == 1 else noun + "s"}'

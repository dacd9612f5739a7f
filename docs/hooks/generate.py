"""MkDocs hooks: pages generated from the code, so they cannot drift from it.

* ``<!-- zros:cli -->`` becomes the help of every ``zros`` command and subcommand, formatted by
  the command's own argparse parser (the parser the ``zros`` command runs).
* ``<!-- zros:examples -->`` becomes the list of the scripts in ``examples/``: each one's
  docstring and source.
* In API pages, Sphinx roles left in docstrings (``:class:`Node```) lose the role.
"""

from __future__ import annotations

import argparse
import ast
import html
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / 'examples'
WIDTH = 96  # columns of the generated help, whatever the terminal that builds the docs

#: the order examples are presented in; scripts not listed come after, by name
EXAMPLE_ORDER = [
    'rosr_demo0_log.py',
    'rosr_demo1_plot.py',
    'rosr_demo2_fit.py',
    'rosr_demo3_range.py',
    'sharp_sensor.py',
    'talker.py',
    'listener_polling.py',
    'listener_callback.py',
    'asyncio_subscriber.py',
    'add_two_ints_server.py',
    'add_two_ints_client.py',
    'fibonacci_action_server.py',
    'fibonacci_action_client.py',
    'parameters.py',
    'bag_to_numpy.py',
    'real_robot.py',
    'wan_tls.py',
]


def _commands(
    parser: argparse.ArgumentParser, path: tuple[str, ...]
) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    yield path, parser
    seen: set[int] = set()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                if id(child) in seen:  # an alias of a command already listed
                    continue
                seen.add(id(child))
                yield from _commands(child, (*path, name))


def cli_reference() -> str:
    """Markdown: a section per command, with its ``--help`` text."""
    from zros.cli.main import _parser

    sections = []
    for path, parser in _commands(_parser(), ('zros',)):
        parser.formatter_class = lambda prog: argparse.HelpFormatter(prog, width=WIDTH)
        level = '#' * min(len(path) + 1, 4)
        text = parser.format_help().rstrip()
        sections.append(f'{level} {" ".join(path)}\n\n```text\n{text}\n```\n')
    return '\n'.join(sections)


def _example_files() -> list[Path]:
    scripts = {path.name: path for path in EXAMPLES.glob('*.py')}
    ordered = [scripts.pop(name) for name in EXAMPLE_ORDER if name in scripts]
    return ordered + [scripts[name] for name in sorted(scripts)]


def _docstring_markdown(text: str) -> str:
    """A module docstring as Markdown: ``::`` before a literal block becomes ``:``."""
    return re.sub(r'::\n', ':\n', text)


def examples_listing() -> str:
    """Markdown: every example's docstring, then its source in a fold."""
    parts = []
    for path in _example_files():
        source = path.read_text()
        module = ast.parse(source)
        docstring = ast.get_docstring(module) or ''
        body = source
        if module.body and isinstance(module.body[0], ast.Expr) and docstring:
            body = '\n'.join(source.splitlines()[module.body[0].end_lineno :]).lstrip('\n')
        parts.append(
            f'## {path.name}\n\n{_docstring_markdown(docstring)}\n\n'
            f'<details><summary>Source of examples/{path.name}</summary>\n'
            f'<pre><code class="language-python">{html.escape(body)}</code></pre>\n'
            '</details>\n'
        )
    others = sorted(p for p in EXAMPLES.rglob('*') if p.is_file() and p.suffix != '.py')
    if others:
        parts.append('## Other files\n')
        for path in others:
            if '__pycache__' in path.parts:
                continue
            relative = path.relative_to(ROOT)
            parts.append(
                f'<details><summary>{relative}</summary>\n'
                f'<pre><code>{html.escape(path.read_text())}</code></pre>\n</details>\n'
            )
    return '\n'.join(parts)


GENERATORS = {
    '<!-- zros:cli -->': cli_reference,
    '<!-- zros:examples -->': examples_listing,
}


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    for marker, generate in GENERATORS.items():
        if marker in markdown:
            markdown = markdown.replace(marker, generate())
    return markdown


_ROLE = re.compile(r':(?:py:)?(?:class|func|meth|attr|mod|data|exc|obj):(?=<code>)')


def on_page_content(content: str, page: Any, config: Any, files: Any) -> str:
    return _ROLE.sub('', content)

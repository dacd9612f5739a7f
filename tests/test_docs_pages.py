"""The documentation pages in docs/ hold their generated parts (CLI and API references, examples)
as committed Markdown, so they read on GitHub too; they must match what the code gives now."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / 'docs'


@pytest.fixture(scope='module')
def generate() -> ModuleType:
    """docs/generate.py, the script that writes the generated parts."""
    spec = importlib.util.spec_from_file_location('docs_generate', DOCS / 'generate.py')
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_generated_parts_are_up_to_date(generate: ModuleType) -> None:
    pages = generate.pages()
    names = {p.relative_to(DOCS).as_posix() for p in pages}
    assert {'cli.md', 'examples.md', 'api/node.md', 'api/pubsub.md', 'api/bag.md'} <= names
    versions = {
        version for page in pages for version in generate.GENERATED_BY.findall(page.read_text())
    }
    running = f'{sys.version_info.major}.{sys.version_info.minor}'
    if versions != {running}:
        pytest.skip(f'the pages were written with Python {versions}; argparse and inspect differ')
    stale = [p.relative_to(ROOT).as_posix() for p in generate.stale_pages()]
    assert stale == [], 'run python docs/generate.py (and commit the pages)'


def test_a_changed_docstring_makes_its_page_stale(generate: ModuleType) -> None:
    page = (DOCS / 'api' / 'pubsub.md').read_text()
    edited = page.replace('Publish CDR bytes (4-byte header included)', 'Old text')
    assert edited != page
    assert generate.expand(edited) == generate.expand(page)
    assert generate.expand(edited) != edited


def test_no_placeholder_is_left_for_the_site_to_fill() -> None:
    # what mkdocs plugins used to fill at build time, invisible on GitHub
    for page in DOCS.rglob('*.md'):
        text = page.read_text()
        assert not re.search(r'^::: ', text, re.M), page
        assert '<!-- zros:' not in text, page


def test_the_references_read_as_markdown(generate: ModuleType) -> None:
    cli = (DOCS / 'cli.md').read_text()
    assert '## zros topic\n' in cli and '#### zros topic echo\n' in cli
    assert 'usage: zros topic hz [-h]' in cli
    node = (DOCS / 'api' / 'node.md').read_text()
    assert '## zros.node.Node\n' in node
    assert '### Node.create_publisher\n' in node
    assert ':class:`' not in node and '``' not in node.replace('```', '')
    examples = (DOCS / 'examples.md').read_text()
    assert '## talker.py\n' in examples
    assert 'Source of examples/talker.py' in examples

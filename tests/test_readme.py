"""Every Python example in the README runs."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parent.parent / 'README.md'
BLOCKS = re.findall(r'```python\n(.*?)```', README.read_text(), flags=re.DOTALL)


@pytest.mark.parametrize('code', BLOCKS, ids=[f'block{i}' for i in range(len(BLOCKS))])
def test_readme_example_runs(code: str, capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    if 'def test_' in code:
        # an example test: run it with pytest, which loads the zros plugin and its fixtures
        test_file = tmp_path / 'test_readme_example.py'
        test_file.write_text(code)
        result = subprocess.run(
            [sys.executable, '-m', 'pytest', str(test_file), '-q', '-p', 'no:cacheprovider'],
            capture_output=True,
            text=True,
            timeout=120,
            cwd=tmp_path,
            check=False,
        )
        assert result.returncode == 0, result.stdout + result.stderr
        assert ' passed' in result.stdout
        return
    exec(compile(code, str(README), 'exec'), {'__name__': '__readme__'})
    assert capsys.readouterr().out  # every example prints what it shows


def test_readme_has_examples() -> None:
    assert BLOCKS

"""The README's Python snippets run as printed (so they never rot)."""

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
SNIPPETS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_the_readme_has_python_snippets():
    assert SNIPPETS


@pytest.mark.parametrize("index", range(len(SNIPPETS)))
def test_readme_snippet_runs(index, monkeypatch, capsys):
    monkeypatch.chdir(README.parent)  # snippets use paths relative to the project
    exec(compile(SNIPPETS[index], f"README.md python snippet {index}", "exec"), {})

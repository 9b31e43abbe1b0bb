"""The documentation site stands without a network: its mathematics is typeset by a
MathJax copied into the site (the ``docs`` extra's sphinx-mathjax-offline), not one
loaded from a CDN (issue 31).  The site is built by .ci/run before the tests; where
it is (docs/_build/html), its pages are checked too."""
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SITE = ROOT / "docs" / "_build" / "html"
EXTENSION = "sphinx-mathjax-offline"


def _docs_extra() -> list[str]:
    if sys.version_info >= (3, 11):
        import tomllib
    else:
        import tomli as tomllib
    with open(ROOT / "pyproject.toml", "rb") as fh:
        return tomllib.load(fh)["project"]["optional-dependencies"]["docs"]


def test_mathjax_comes_with_the_docs_extra():
    conf = (ROOT / "docs" / "conf.py").read_text(encoding="utf-8")
    extensions = re.search(r"^extensions = \[(.*?)^\]", conf, flags=re.MULTILINE | re.DOTALL)
    assert extensions and f'"{EXTENSION}"' in extensions.group(1)
    assert "mathjax_path" not in conf            # the extension sets it to the copy
    assert any(req.startswith(EXTENSION) for req in _docs_extra())


def test_the_built_pages_load_the_local_mathjax():
    page = SITE / "index.html"
    if not page.is_file():
        pytest.skip("the site is not built (sphinx-build -b html docs docs/_build/html)")
    html = page.read_text(encoding="utf-8")
    scripts = re.findall(r'<script[^>]*src="([^"]*mathjax[^"]*)"', html, flags=re.IGNORECASE)
    assert scripts, "index.html loads no MathJax (its mathematics shows as raw TeX)"
    for src in scripts:
        assert not re.match(r"(https?:)?//", src), f"MathJax from the network: {src}"
        assert (page.parent / src).is_file(), f"{src} is not in the site"


# -- the README is a front page; the tables it held are on the site (issue 31) ----------
README = ROOT / "README.md"
QUICK_START = [
    "python3 -m venv .venv && . .venv/bin/activate && pip install . && fpk-vibro run "
    "examples/fig3_energy.toml",
    "python3 -m venv .venv && . .venv/bin/activate && pip install '.[test]' && python -m "
    "pytest -q",
]


def test_the_readme_is_a_front_page():
    text = README.read_text(encoding="utf-8")
    lines = text.splitlines()
    for command in QUICK_START:
        assert command in lines, command                 # the two commands, as they are
    assert len(lines) < 250, len(lines)
    for moved in ("<!-- keys:", "| fault | what survives |", "## What accuracy costs",
                  "## Where averaging holds", "## Benchmarks"):
        assert moved not in text, f"{moved!r} is on the documentation site, not here"
    # every local link of the front page leads to a file of the repository
    for target in re.findall(r"\]\(([^)#]+)\)", text):
        if not re.match(r"[a-z]+:", target):
            assert (ROOT / target).exists(), target


def test_the_readme_examples_run():
    """The example of each method, run in order as written (a few seconds)."""
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"),
                        flags=re.DOTALL)
    assert len(blocks) >= 4
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(README), "exec"), namespace)
    assert {"avg", "fe", "mc"} <= set(namespace)


def test_every_test_the_fault_table_names_exists():
    """The fault table (docs/guide/scenes.md, moved from the README) names the test
    guarding each row: each file and test function is there."""
    page = (ROOT / "docs" / "guide" / "scenes.md").read_text(encoding="utf-8")
    table = page[page.index("| fault | what survives |"):]
    table = table[:table.index("\n\n")]
    named = 0
    for row in table.splitlines()[2:]:
        guarded = row.rstrip(" |").rsplit("|", 1)[-1]
        path = None
        for ref in re.findall(r"`(tests/[\w/]+\.py)?(?:::(\w+))?[^`]*`", guarded):
            path = ROOT / ref[0] if ref[0] else path
            assert path is not None and path.is_file(), (row, ref)
            if ref[1]:
                assert re.search(rf"^def {ref[1]}\(", path.read_text(encoding="utf-8"),
                                 flags=re.MULTILINE), (path.name, ref[1])
            named += 1
    assert named >= 15

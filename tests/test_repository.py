"""The repository stands on its own: no reference to files outside it, every cited
section of the theory page exists, and the licence and citation metadata are present
and agree with the package version (issue #17)."""
import importlib.metadata
import re
import sys
from pathlib import Path

import pytest

import fpk_vibro

ROOT = Path(__file__).resolve().parent.parent

#: References to material that is not in the repository (the design notes, the local
#: copy of the paper, the shared folder beside the checkout).  Written in pieces so
#: that this file does not match itself.
OUTSIDE = re.compile("|".join([
    "DES" + "IGN" + r"\s*(§|\.md)",
    "seed" + "-paper",
    r"\.\./" + "shared",
    "/work/" + "shared",
    "/tmp/" + r"[\w.-]+\.py",          # a private script
]))

#: Where to look, relative to the repository root.
SCANNED = ["fpk_vibro", "tests", "docs", "meshes", "README.md", "CHANGELOG.md",
           "CITATION.cff", "pyproject.toml"]
TEXT_SUFFIXES = {".py", ".md", ".rst", ".txt", ".toml", ".cff", ".cfg", ".ini", ".yml",
                 ".yaml", ".css", ".html"}
#: Generated or cached trees that are not sources (sphinx output, the gallery pages
#: sphinx-gallery writes from examples/gallery, byte code).
SKIPPED_DIRS = {"_build", "__pycache__", ".ipynb_checkpoints", "gallery", "_generated"}
#: Files that describe the citation syntax rather than cite.
NOT_CITING = {"docs/conf.py"}


def _files():
    for name in SCANNED:
        path = ROOT / name
        if path.is_file():
            yield path
        elif path.is_dir():
            for p in sorted(path.rglob("*")):
                rel = p.relative_to(ROOT)
                if (p.is_file() and p.suffix in TEXT_SUFFIXES
                        and not SKIPPED_DIRS.intersection(rel.parts[:-1])):
                    yield p


def _offending_lines(path: Path) -> list[str]:
    text = path.read_text(encoding="utf-8", errors="replace")
    return [f"{path.relative_to(ROOT).as_posix()}:{i}: {line.strip()}"
            for i, line in enumerate(text.splitlines(), 1) if OUTSIDE.search(line)]


def test_no_references_to_files_outside_the_repository():
    found = [line for p in _files()
             for line in _offending_lines(p)]
    assert not found, ("cite docs/theory.md (its sections) or the published paper "
                       "instead:\n" + "\n".join(found))


def _headings(page: str) -> list[str]:
    text = (ROOT / "docs" / page).read_text(encoding="utf-8")
    return re.findall(r"^##+ (.+?)\s*$", text, flags=re.MULTILINE)


@pytest.mark.parametrize("page", ["theory.md", "measurements.md"])
def test_cited_sections_exist(page):
    """Every "docs/<page>, §Name" in the sources names a heading of that page."""
    names = sorted(_headings(page), key=len, reverse=True)
    assert names
    cite = re.compile(r"docs/" + re.escape(page) + r"(?P<tail>[^()]*?)(?:[()]|\.\s|\.$|\"\"\")",
                      flags=re.MULTILINE)
    missing = []
    for p in _files():
        if p.name == page or p.relative_to(ROOT).as_posix() in NOT_CITING:
            continue
        text = p.read_text(encoding="utf-8", errors="replace")
        for m in cite.finditer(text):
            for ref in m.group("tail").split("§")[1:]:
                ref = " ".join(ref.split())
                if not any(ref.startswith(n) for n in names):
                    missing.append(f"{p.relative_to(ROOT).as_posix()}: §{ref}")
    assert not missing, f"sections not in docs/{page}:\n" + "\n".join(missing)


def test_theory_lists_its_sections_at_the_top():
    text = (ROOT / "docs" / "theory.md").read_text(encoding="utf-8")
    top = text.split("\n## ", 1)[0]
    for name in _headings("theory.md"):
        assert f"[{name}]" in top, name


# -- licence, citation, version ---------------------------------------------------------
def _pyproject_version() -> str:
    if sys.version_info >= (3, 11):
        import tomllib
    else:
        import tomli as tomllib
    with open(ROOT / "pyproject.toml", "rb") as fh:
        return tomllib.load(fh)["project"]["version"]


def _citation() -> dict:
    """CITATION.cff as a mapping: PyYAML where installed (not a dependency), else the
    top-level scalar keys read by a regex."""
    text = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    try:
        import yaml
    except ImportError:
        out = {}
        for m in re.finditer(r"^([A-Za-z][\w-]*):\s*(.*)$", text, flags=re.MULTILINE):
            value = m.group(2).strip()
            out[m.group(1)] = value.strip("'\"") if value else None
        out["_text"] = text
        return out
    data = yaml.safe_load(text)
    assert isinstance(data, dict)
    data["_text"] = text
    return data


def test_license_is_bsd_3_clause():
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert "BSD 3-Clause License" in text
    assert "the fpk_vibro developers" in text
    assert "Neither the name of the copyright holder" in text


def test_citation_file():
    cff = _citation()
    for key in ("cff-version", "message", "title", "version", "authors", "license",
                "abstract", "references"):
        assert key in cff, key
    assert str(cff["cff-version"]) == "1.2.0"
    assert str(cff["license"]) == "BSD-3-Clause"
    assert "fpk_vibro developers" in cff["_text"]
    assert "10.1016/j.chaos.2016.03.017" in cff["_text"]          # Yang et al. 2016
    if isinstance(cff["references"], list):
        ref = cff["references"][0]
        assert ref["year"] == 2016 and ref["authors"][0]["family-names"] == "Yang"


def test_one_version():
    """pyproject.toml holds the version; the package reports it, CITATION.cff repeats it."""
    version = _pyproject_version()
    assert str(_citation()["version"]) == version
    if fpk_vibro.__version__ == "0+unknown":
        pytest.skip("fpk_vibro is not installed: no metadata to read the version from")
    assert fpk_vibro.__version__ == version
    assert str(_citation()["version"]) == fpk_vibro.__version__


def test_version_without_metadata(monkeypatch):
    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)
    monkeypatch.setattr(importlib.metadata, "version", missing)
    assert fpk_vibro._installed_version() == "0+unknown"


def test_typed_marker_is_shipped():
    assert (ROOT / "fpk_vibro" / "py.typed").is_file()
    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert re.search(r'^\[tool\.setuptools\.package-data\]\s*\nfpk_vibro = \[[^\]]*"py\.typed"',
                     text, flags=re.MULTILINE)

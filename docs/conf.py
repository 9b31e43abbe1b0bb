"""Sphinx configuration of the fpk_vibro documentation.

Build (warnings are errors, as in CI)::

    pip install '.[docs]'
    sphinx-build -W -b html docs docs/_build/html

The example gallery (``examples/gallery/plot_*.py``) is executed by sphinx-gallery at
build time (a few seconds each); ``-D plot_gallery=0`` builds the pages without
running them.  Command output shown in the user guide (``python -m fpk_vibro keys``
and ``--help`` of every command) is produced at build time, see ``_generated``.
"""
from __future__ import annotations

import contextlib
import io
import os
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
# document (and run the gallery against) the working tree, not an installed copy
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MPLBACKEND", "Agg")

import fpk_vibro  # noqa: E402

# -- project ------------------------------------------------------------------------
project = "fpk_vibro"
author = "the fpk_vibro developers"
copyright = "the fpk_vibro developers, BSD-3-Clause"
release = fpk_vibro.__version__
version = ".".join(release.split(".")[:2])

# -- general ------------------------------------------------------------------------
extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    # MathJax from the package, copied to _static/mathjax: the mathematics renders
    # without a network (sphinx.ext.mathjax alone loads it from a CDN)
    "sphinx-mathjax-offline",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = [
    "_build",
    "**/.ipynb_checkpoints",
    # sphinx-gallery writes these next to the generated pages; they are no sources
    "guide/gallery/*.ipynb",
    "guide/gallery/*.py",
    "guide/gallery/*.zip",
    "guide/gallery/*.json",
]
# -W builds with every warning category on: the docstring fixes below
# (_process_docstring, _resolve_alias) make suppress_warnings unnecessary.
nitpicky = False              # references Sphinx cannot resolve stay plain text

# -- MyST (the Markdown pages) ------------------------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_dmath_double_inline = True
myst_heading_anchors = 3

# -- autodoc / autosummary / numpydoc -----------------------------------------------
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"            # numpydoc's Parameters say the types
autosummary_generate = False          # the API pages are written by hand (docs/api/)
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
# types in Parameters/Returns: link the package's classes, leave every other word
numpydoc_xref_param_type = True
numpydoc_xref_ignore = "all"
numpydoc_xref_aliases = {
    name: f"{module}.{name}" for module, names in {
        "fpk_vibro.model": ("VibroImpactSystem", "Wall"),
        "fpk_vibro.solution": ("Solution",),
        "fpk_vibro.averaging": ("AveragedSolution", "EnergyGridSolution"),
        "fpk_vibro.fem": ("FEMSolution", "Discretisation", "Domain"),
        "fpk_vibro.montecarlo": ("MonteCarloSolution", "TransientRun"),
        "fpk_vibro.exact": ("GibbsSolution",),
        "fpk_vibro.first_passage": ("FirstPassage",),
    }.items() for name in names
}
# numpydoc's own aliases point to the Python and NumPy docs as :ref:/:term: (which
# warn without intersphinx, and intersphinx needs the network): plain names instead
numpydoc_xref_aliases.update({
    "bool": "bool", "boolean": "bool", "iterable": "collections.abc.Iterable",
    "sequence": "collections.abc.Sequence", "generator": "collections.abc.Generator",
    "array-like": "numpy.typing.ArrayLike", "array_like": "numpy.typing.ArrayLike",
    "scalar": "numpy.generic",
})

# -- sphinx-gallery -----------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples" / "gallery"),
    "gallery_dirs": "guide/gallery",
    "filename_pattern": r"/plot_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "write_computation_times": False,   # no sg_execution_times.rst in the tree
    "min_reported_time": 0,
    "show_memory": False,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "capture_repr": (),
}

# -- HTML ---------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"fpk_vibro {release}"
html_static_path = ["_static"]
html_css_files = ["fpk_vibro.css"]
html_show_sourcelink = False
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 6,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_sidebars = {"**": ["sidebar-nav-bs"], "index": [], "guide/getting_started": [],
                 "theory": []}


# -- generated text: command output pasted into pages at build time -----------------
# A line ``<!-- output of: fpk-vibro ARGS -->`` in a Markdown page is replaced by
# what ``python -m fpk_vibro ARGS`` prints: Markdown as is (``keys``), anything else
# in a text block.  Nothing is written to the source tree.
_MARKER = re.compile(r"^<!-- output of: fpk-vibro (?P<args>[^>]*?) -->$", re.MULTILINE)
_OUTPUT_CACHE: dict[str, str] = {}


def _command_output(args: str) -> str:
    """What ``python -m fpk_vibro ARGS`` prints (run in this process)."""
    if args not in _OUTPUT_CACHE:
        from fpk_vibro.app import cli

        buf = io.StringIO()
        old = os.environ.get("COLUMNS")
        os.environ["COLUMNS"] = "88"             # argparse's wrapping, stable
        try:
            with contextlib.redirect_stdout(buf):
                try:
                    code = cli.main(args.split())
                except SystemExit as exc:        # --help exits 0
                    code = exc.code
        finally:
            if old is None:
                os.environ.pop("COLUMNS", None)
            else:
                os.environ["COLUMNS"] = old
        if code not in (0, None):
            raise RuntimeError(f"`fpk-vibro {args}` exited {code}")
        _OUTPUT_CACHE[args] = buf.getvalue().rstrip("\n")
    return _OUTPUT_CACHE[args]


def _generated(app, docname: str, source: list[str]) -> None:
    def paste(m: re.Match) -> str:
        args = m.group("args").strip()
        text = _command_output(args)
        if args == "keys":
            return text
        return f"```text\n$ fpk-vibro {args}\n{text}\n```"

    source[0] = _MARKER.sub(paste, source[0])


def _reread_generated(app, env, added, changed, removed) -> list[str]:
    """Pages with command output are read again on every build (the output may
    change while the page does not)."""
    return [doc for doc in env.found_docs
            if (page := DOCS / f"{doc}.md").is_file()
            and _MARKER.search(page.read_text(encoding="utf-8"))]


# -- docstrings: |x| is an absolute value, not a reST substitution ------------------
# The package's docstrings write plain-text mathematics such as |x| < Δ or |Re λ|,
# which reST reads as substitution references ("Undefined substitution referenced").
# Outside literal blocks, doctests and inline literals/roles, every bar that could
# start or end inline markup is escaped, so it shows as written.
_LITERAL_SPANS = re.compile(r"(``.+?``|:[\w:+-]+:`[^`]*`|`[^`]*`_{0,2})")
_BAR = re.compile(r"(?<!\\)\|(?=\S)|(?<=\S)(?<!\\)\|")


def _escape_bars_in(text: str) -> str:
    parts = _LITERAL_SPANS.split(text)
    return "".join(part if i % 2 else _BAR.sub(r"\\|", part)
                   for i, part in enumerate(parts))


def _prose_runs(lines: list[str]):
    """(start, stop) of the runs of prose lines: not in literal blocks or doctests."""
    literal_indent = None      # indentation of the paragraph opening a literal block
    doctest = False
    prose = []
    for line in lines:
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None:
            if not stripped or indent > literal_indent:
                prose.append(False)
                continue
            literal_indent = None
        if doctest and stripped:
            prose.append(False)
            continue
        doctest = stripped.startswith(">>>")
        if stripped.endswith("::"):
            literal_indent = indent
        prose.append(not doctest)
    i = 0
    while i < len(lines):
        if prose[i]:
            j = i
            while j < len(lines) and prose[j]:
                j += 1
            yield i, j
            i = j
        else:
            i += 1


def _escape_bars(lines: list[str]) -> None:
    for start, stop in _prose_runs(lines):
        for i in range(start, stop):
            stripped = lines[i].strip()
            block = stripped == "|" or stripped.startswith(("| ", "+-", "+="))
            if "|" in lines[i] and not block:       # line blocks and grid tables stay
                lines[i] = _escape_bars_in(lines[i])


# -- docstrings: "docs/theory.md, §Name" becomes a link -----------------------------
# The package cites the pages of this site as ``docs/FILE.md`` and their sections as
# ``docs/FILE.md, §Heading`` (later ``§Heading`` in the same docstring: the same
# file).  A section is linked when the page gives its heading a MyST label,
# ``(label)=`` on the line before it; anything unknown stays plain text.
def _section_labels() -> dict[str, dict[str, str]]:
    out: dict[str, dict[str, str]] = {}
    for page in DOCS.glob("*.md"):
        lines = page.read_text(encoding="utf-8").splitlines()
        labels = {}
        for prev, line in zip(lines, lines[1:]):
            m = re.fullmatch(r"\((?P<label>[\w.-]+)\)=", prev.strip())
            h = re.match(r"#+\s+(?P<title>.+?)\s*$", line)
            if m and h:
                labels[h.group("title")] = m.group("label")
        out[page.stem] = labels
    return out


_SECTIONS = _section_labels()
_CITE = re.compile(r"docs/(?P<page>\w+)\.md(?P<sec>,\s+§)?|§")


def _heading_at(text: str, pos: int, page: str) -> tuple[str, str] | None:
    """(matched text, label) of the longest known heading of ``page`` at ``pos``
    (words may be split across lines)."""
    best = None
    for title, label in _SECTIONS.get(page, {}).items():
        pattern = r"\s+".join(map(re.escape, title.split())) + r"(?![\w-])"
        m = re.compile(pattern).match(text, pos)
        if m and (best is None or len(m.group()) > len(best[0])):
            best = (m.group(), label)
    return best


def _link_citations_in(text: str) -> str:
    page = "theory"
    out, pos = [], 0
    for m in _CITE.finditer(text):
        if m.start() < pos:
            continue
        if m.group("page"):
            if m.group("page") not in _SECTIONS:
                continue
            page = m.group("page")
            found = _heading_at(text, m.end(), page) if m.group("sec") else None
            if found:
                end = m.end() + len(found[0])
                role = f":ref:`{text[m.start():end]} <{found[1]}>`"
            else:
                end = m.start() + len(f"docs/{page}.md")
                role = f":doc:`docs/{page}.md </{page}>`"
        else:
            found = _heading_at(text, m.end(), page)
            if not found:
                continue
            end = m.end() + len(found[0])
            role = f":ref:`§{found[0]} <{found[1]}>`"
        out += [text[pos:m.start()], role]
        pos = end
    return "".join(out) + text[pos:]


def _link_citations(lines: list[str]) -> None:
    for start, stop in _prose_runs(lines):
        text = "\n".join(lines[start:stop])
        if "docs/" not in text and "§" not in text:
            continue
        parts = _LITERAL_SPANS.split(text)
        text = "".join(part if i % 2 else _link_citations_in(part)
                       for i, part in enumerate(parts))
        lines[start:stop] = text.split("\n")   # as many lines: the roles keep them


def _process_docstring(app, what, name, obj, options, lines) -> None:
    _escape_bars(lines)
    _link_citations(lines)


# -- cross-references to re-exported names ------------------------------------------
# Docstrings name objects by where they are defined (fpk_vibro.fem.solution.FEMSolution)
# or by a re-export (fpk_vibro.VibroImpactSystem); the API pages document each object
# once, under one of its names.  A reference Sphinx cannot find is resolved to the
# documented name of the same Python object (classes, functions, modules, properties).
_DOCUMENTED: dict[int, str] | None = None


def _object(name: str):
    """The object a dotted name imports to, or None."""
    import importlib
    import inspect

    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except Exception:
            continue
        try:
            for part in parts[i:]:
                obj = getattr(obj, part)
        except AttributeError:
            return None
        kinds = (inspect.isclass, inspect.isfunction, inspect.ismodule, inspect.ismethod)
        if any(k(obj) for k in kinds) or isinstance(obj, property):
            return obj
        return None
    return None


def _resolve_alias(app, env, node, contnode):
    global _DOCUMENTED
    if node.get("refdomain") != "py" or not node.get("reftarget"):
        return None
    domain = env.get_domain("py")
    if _DOCUMENTED is None:
        _DOCUMENTED = {}
        for name in sorted(domain.objects, key=len):   # shortest name wins
            obj = _object(name)
            if obj is not None:
                _DOCUMENTED.setdefault(id(obj), name)
    target = node["reftarget"].lstrip("~.")
    mod, cls = node.get("py:module"), node.get("py:class")
    candidates = [target]
    if mod and cls:
        candidates.append(f"{mod}.{cls}.{target}")
    if mod:
        candidates.append(f"{mod}.{target}")
    for cand in candidates:
        if not cand.startswith("fpk_vibro"):
            continue
        obj = _object(cand)
        name = _DOCUMENTED.get(id(obj)) if obj is not None else None
        if name:
            return domain.resolve_xref(env, node["refdoc"], app.builder, "obj", name,
                                       node, contnode)
    return None


def setup(app):
    app.connect("source-read", _generated)
    app.connect("env-get-outdated", _reread_generated)
    # before numpydoc (priority 500) rewrites the sections
    app.connect("autodoc-process-docstring", _process_docstring, priority=400)
    app.connect("missing-reference", _resolve_alias)
    return {"parallel_read_safe": True}

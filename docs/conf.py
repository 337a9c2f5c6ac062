"""Sphinx configuration of the discgym documentation site.

Build: ``pip install -e ".[docs]"`` then ``sphinx-build -W --keep-going -b html docs
docs/_build/html``. The per-task pages (``docs/tasks/``) and the table of built-in scenes
(``docs/_generated/``) are generated from the code when the build starts
(``docs/_scripts/gen_pages.py``); the task GIFs (``docs/img/tasks/``) are made once by
``docs/_scripts/make_gifs.py`` and only referenced here.
"""

from __future__ import annotations

import importlib.util
import inspect
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(DOCS / "_scripts"))

import gen_pages  # noqa: E402  (docs/_scripts)
from sphinx.ext import napoleon  # noqa: E402

import discgym  # noqa: E402  (the path above first)

project = "discgym"
author = "the discgym developers"
copyright = "the discgym developers, MIT licence"
release = version = discgym.__version__
#: Where links to repository files outside docs/ point (README.md, benchmarks/, ...).
REPOSITORY = "https://github.com/discgym/discgym"
BLOB = f"{REPOSITORY}/blob/main"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",  # Scene's and Simulation's "Arguments:" blocks are Google-style
    "sphinx.ext.linkcode",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "_scripts", "_generated", "data", "Thumbs.db", ".DS_Store"]
templates_path: list[str] = []

# --------------------------------------------------------------------------------------------
# MyST

myst_enable_extensions = ["colon_fence", "dollarmath", "amsmath"]
# anchors for the headings the pages link to (performance.md#scaling-with-n-and-threads)
myst_heading_anchors = 4
# Some guide pages start at "##" (they were README sections): a page title all the same.
suppress_warnings = ["myst.header"]

# --------------------------------------------------------------------------------------------
# autodoc

autodoc_member_order = "bysource"
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_typehints = "signature"
# (Gymnasium's own docstrings of reset/step are not ours, nor in our markup)
autodoc_inherit_docstrings = False
napoleon_google_docstring = True
napoleon_numpy_docstring = False
# The optional RL stacks the adapters wrap: documented without them when not installed.
autodoc_mock_imports = [m for m in ("stable_baselines3", "sb3_contrib", "torch")
                        if importlib.util.find_spec(m) is None]

# --------------------------------------------------------------------------------------------
# HTML

html_theme = "furo"
html_title = f"discgym {release}"
html_static_path: list[str] = []
html_theme_options = {
    "source_repository": REPOSITORY,
    "source_branch": "main",
    "source_directory": "docs/",
}


def linkcode_resolve(domain: str, info: dict) -> str | None:
    """The source of a documented object on the repository (``[source]`` links)."""
    if domain != "py" or not info.get("module"):
        return None
    obj = sys.modules.get(info["module"])
    for part in info["fullname"].split("."):
        obj = getattr(obj, part, None)
    obj = inspect.unwrap(obj) if obj is not None else None
    try:
        path = Path(inspect.getsourcefile(obj)).resolve().relative_to(ROOT)
        lines, start = inspect.getsourcelines(obj)
    except (TypeError, OSError, ValueError):
        return None
    return f"{BLOB}/{path.as_posix()}#L{start}-L{start + len(lines) - 1}"


# --------------------------------------------------------------------------------------------
# the project's own hooks

_HEADING = re.compile(r"^(\s*)#{2,4} (\S.*)$")


def _docstring_sections(app, what, name, obj, options, lines: list[str]) -> None:
    """The env docstrings follow Gymnasium's layout (``## Description``, ``## Action
    Space``, ...), Markdown headings that reStructuredText would print as text: make them
    rubrics. ``|x|`` (an absolute value) would be a substitution: escape it. Then napoleon,
    for the "Arguments:" blocks, except on properties and attributes: their docstrings read
    "What it is: more", which napoleon would take for "type: description"."""
    if what not in ("property", "attribute", "data"):
        napoleon._process_docstring(app, what, name, obj, options, lines)
    out = []
    for line in lines:
        m = _HEADING.match(line)
        out += [f"{m.group(1)}.. rubric:: {m.group(2)}", ""] if m else [line]
    # (as one text: a literal may span lines)
    lines[:] = gen_pages.escape_bars("\n".join(out)).split("\n")


def _repository_links(app, doctree) -> None:
    """Markdown links to files of the repository outside docs/ (``../README.md#arguments``,
    ``../benchmarks/ladder.py``) become links to those files on the repository, instead of
    missing documents or downloads."""
    from docutils import nodes
    from sphinx import addnodes

    here = Path(app.env.doc2path(app.env.docname)).parent
    for node in list(doctree.findall(addnodes.pending_xref)) + \
            list(doctree.findall(addnodes.download_reference)):
        if node.get("reftype") != "myst":
            continue
        target = node.get("reftarget", "")
        if isinstance(node, addnodes.pending_xref):
            # (a link to a .md file outside docs/ arrives as a document name: the path
            # without its suffix; the anchor is kept apart)
            if node.get("refdomain") != "doc" or target in app.env.found_docs:
                continue
            path, anchor = target, node.get("reftargetid") or ""
            candidates = [here / f"{path}{suffix}" for suffix in app.config.source_suffix]
        else:
            path, _, anchor = target.partition("#")
            candidates = [here / path]
        found = [c.resolve() for c in candidates if c.is_file()]
        if not found or ROOT not in found[0].parents or DOCS in found[0].parents:
            continue
        rel = found[0].relative_to(ROOT)
        uri = f"{BLOB}/{rel.as_posix()}" + (f"#{anchor}" if anchor else "")
        ref = nodes.reference("", "", *node.children, internal=False, refuri=uri)
        node.replace_self(ref)


def _generate(app) -> None:
    gen_pages.write_all(DOCS)


def setup(app):
    app.connect("builder-inited", _generate)
    # napoleon runs from _docstring_sections (not on properties)
    for listener in list(app.events.listeners.get("autodoc-process-docstring", [])):
        if listener.handler is napoleon._process_docstring:
            app.disconnect(listener.id)
    app.connect("autodoc-process-docstring", _docstring_sections)
    app.connect("doctree-read", _repository_links)
    return {"parallel_read_safe": True}

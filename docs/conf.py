"""Sphinx configuration of the skfem_sheet documentation.

Build: ``pip install ".[docs]"`` then ``python -m sphinx -W -b html docs OUT``.
The notebooks of ``notebooks/`` are copied into the source tree at build time and
executed (about a minute in all), so their outputs are always those of the code.
"""
import logging
import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

import skfem_sheet  # noqa: E402  (the installed package; fails loudly if it is not)

project = "skfem_sheet"
author = "the skfem_sheet developers"
release = version = skfem_sheet.__version__
copyright = "the skfem_sheet developers"

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "myst_nb",
]
templates_path = ["_templates"]
exclude_patterns = ["_build", "**.ipynb_checkpoints", "jupyter_execute"]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}

# -- API reference: numpy-style docstrings -------------------------------------------------
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {"members": True, "ignore-module-all": True,
                           "member-order": "bysource"}
autodoc_typehints = "none"          # the docstrings' Parameters sections say the types
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
napoleon_use_ivar = True            # Attributes sections as fields: ``u``, ``p``, ``length``
                                    # of the result dataclasses are not global targets


def _skip_reexports(app, what, name, obj, skip, options):
    """Document an object once, in the module that defines it (not where it is
    imported or aliased)."""
    if what == "module" and getattr(obj, "__module__", None) not in (None, options.get("module")):
        return skip
    return None

# -- Markdown and notebooks ----------------------------------------------------------------
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3
nb_execution_mode = "force"         # every notebook runs in the build (a minute in all)
nb_execution_timeout = 900
nb_execution_raise_on_error = True  # a notebook that fails fails the build
nb_execution_in_temp = True         # the files they write go to a temporary folder

html_theme = "alabaster"
html_title = f"skfem_sheet {version}"
html_static_path = []

# The notebooks live in notebooks/ (where test_notebooks runs them); a copy is documented.
_NB = HERE / "notebooks"
if _NB.exists():
    shutil.rmtree(_NB)
shutil.copytree(ROOT / "notebooks", _NB, ignore=shutil.ignore_patterns(".ipynb_checkpoints"))

# The notebooks' kernels inherit this process's environment: an MPLBACKEND set
# here (it was "Agg") makes their matplotlib draw off screen, and their plots
# never reach the pages (0 images on every notebook page).  So this process
# chooses its own backend without the environment, and the kernels keep
# Jupyter's inline one; _check_notebook_images fails the build if a notebook
# page shows no image.
import matplotlib  # noqa: E402

matplotlib.use("Agg")
sys.dont_write_bytecode = True

#: Warnings from docstrings in modules that are being reworked by their owners now,
#: each listed exactly (where, what); they are to be fixed in those files, and an
#: entry that no longer matches anything fails the build (see _check_pending).
PENDING = []
_seen = set()


class _PendingFilter(logging.Filter):
    """Drops exactly the PENDING warnings (before Sphinx counts a warning)."""

    def __init__(self, app):
        super().__init__()
        self.app = app

    def where(self, record):
        from docutils import nodes
        from sphinx.util.logging import get_node_location

        loc = getattr(record, "location", None)
        try:
            if isinstance(loc, nodes.Node):
                return get_node_location(loc) or ""
            if isinstance(loc, tuple):
                loc = loc[0]
            if isinstance(loc, str) and loc:
                return f"{self.app.env.doc2path(loc)} {loc}"
        except Exception:  # noqa: BLE001  (a location we cannot read is not pending)
            return str(loc)
        return ""

    def filter(self, record):
        where = self.where(record)
        text = record.getMessage()
        for i, (place, what) in enumerate(PENDING):
            if place in where.replace(str(ROOT) + "/", "") and what in text:
                _seen.add(i)
                return False
        return True


def _check_pending(app, exception):
    unused = [PENDING[i] for i in range(len(PENDING)) if i not in _seen]
    if exception is None and unused:
        raise RuntimeError(f"docs/conf.py PENDING entries match no warning any more: {unused}")


def _check_notebook_images(app, exception):
    """Every notebook page of an HTML build shows at least one image (its plots)."""
    if exception is not None or app.builder.format != "html":
        return
    pages = sorted((Path(app.outdir) / "notebooks").glob("*.html"))
    if not pages:
        raise RuntimeError("the HTML build has no notebook pages (notebooks/*.html)")
    bare = [p.name for p in pages if "<img" not in p.read_text(encoding="utf-8")]
    if bare:
        raise RuntimeError(f"notebook pages without an image: {', '.join(bare)} (their plots "
                           f"did not reach the build: is MPLBACKEND set for the kernels?)")


def setup(app):
    app.connect("autodoc-skip-member", _skip_reexports)
    app.connect("build-finished", _check_pending)
    app.connect("build-finished", _check_notebook_images)
    for handler in logging.getLogger("sphinx").handlers:
        handler.filters.insert(0, _PendingFilter(app))

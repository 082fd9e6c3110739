"""Sphinx configuration of granflow's documentation site.

Build (from the repository root; warnings are errors)::

    python -m pip install -e ".[docs]"
    python -m sphinx -W --keep-going -b html docs docs/_build/html

Why these tools: pydata-sphinx-theme is the theme of SciPy, NumPy and pvlib (readers of
those find their way at once); numpydoc renders granflow's numpydoc docstrings, units in
brackets included; sphinx-gallery turns the runnable ``.py`` files of ``docs/examples`` into
the gallery: each is executed when the site is built (a figure that no longer matches the
code breaks the build), shown with its output and a thumbnail, and offered as a download
(script and notebook) that runs as it is. matplotlib's plot directive draws the figures of
the user guide at build time, and ``_ext/mathtext_svg.py`` draws every formula with
matplotlib's mathtext into an SVG embedded in the page. Nothing is fetched from the network
while building or reading the site: no intersphinx, no MathJax, no fonts or scripts from a
CDN, no LaTeX installation needed.
"""

import os
import sys
from pathlib import Path

from sphinx.ext import autosummary

import granflow

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

project = "granflow"
author = "granflow developers"
copyright = "granflow developers"
version = release = granflow.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "matplotlib.sphinxext.plot_directive",
    "mathtext_svg",
]

# Formulas drawn offline by matplotlib's mathtext (docs/_ext/mathtext_svg.py): no MathJax.
html_math_renderer = "mathtext_svg"

# -- Figures of the user guide (matplotlib's plot directive) ---------------------------------
plot_include_source = False
plot_html_show_source_link = False
plot_html_show_formats = False
plot_formats = [("png", 110)]
plot_rcparams = {"figure.figsize": (6.4, 3.6), "figure.autolayout": True}
plot_pre_code = "import numpy as np\nimport matplotlib.pyplot as plt\nimport granflow as gf"

exclude_patterns = ["_build", "**.ipynb_checkpoints", "examples/README.rst"]
templates_path = ["_templates"]
root_doc = "index"
default_role = "code"
nitpicky = False

# -- API reference (autosummary + numpydoc) ---------------------------------------------------
# autosummary's one-line summary is the docstring's first sentence, found by splitting at the
# first ". " that is not a known abbreviation: a physicist's "Eq. 3" and "Fig. 2c" are
# abbreviations too (without them `fit`'s summary read "Fit Eq.").
# tests/docs/test_summaries.py checks every summary of the API reference is a whole sentence.
SUMMARY_ABBREVIATIONS = ("Eq.", "Eqs.", "Fig.", "Figs.", "cf.", "approx.")
autosummary.WELL_KNOWN_ABBREVIATIONS = tuple(
    dict.fromkeys((*autosummary.WELL_KNOWN_ABBREVIATIONS, *SUMMARY_ABBREVIATIONS))
)
autosummary_generate = True
autosummary_imported_members = True
autodoc_typehints = "none"  # the numpydoc sections carry the types (with units)
numpydoc_show_class_members = False  # the class template documents the members
numpydoc_class_members_toctree = False
numpydoc_validation_checks = set()
numpydoc_xref_param_type = False

# -- Gallery (sphinx-gallery) -----------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",  # every plot_*.py is executed at build time
    "ignore_pattern": r"__init__\.py",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "reset_modules": ("matplotlib",),
    "abort_on_example_error": False,  # report every failing example; -W fails the build
    "only_warn_on_example_error": False,
    "show_memory": False,
    "write_computation_times": False,  # its page loads jQuery and DataTables from a CDN
    "plot_gallery": "True",
    "capture_repr": ("_repr_html_", "__repr__"),
    "matplotlib_animations": False,
    "image_scrapers": ("matplotlib",),
    "min_reported_time": 10,
}
# Examples run on the non-interactive backend, single-threaded, without progress output.
os.environ.setdefault("MPLBACKEND", "Agg")

# -- HTML ---------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"granflow {release}"
html_static_path = ["_static"]
html_css_files = ["granflow.css"]
html_last_updated_fmt = None
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "navbar_align": "left",
    "header_links_before_dropdown": 6,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
# the theme follows the reader's light or dark preference (without it, a page opened from
# disk logs "invalid theme mode" in the console)
html_context = {"default_mode": "auto"}
html_sidebars = {"index": [], "getting_started": []}
html_show_sourcelink = False
html_copy_source = False

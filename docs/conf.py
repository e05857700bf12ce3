"""Sphinx configuration of the inspect-validate manual.

Build: ``python -m sphinx -n -W --keep-going -b html docs docs/_build/html``
(``pip install -e ".[docs]"`` first). Warnings are errors; the gallery's examples run.
"""

import sys
from pathlib import Path

import inspect_validate

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

project = "inspect-validate"
author = "the inspect-validate developers"
copyright = "2026, the inspect-validate developers"
release = version = inspect_validate.__version__

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.doctest",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
    "file_models",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "examples", "auto_examples/*.ipynb", "auto_examples/*.py", "**/*.zip"]
myst_enable_extensions = ["dollarmath", "deflist"]
myst_heading_anchors = 3
suppress_warnings = []

autosummary_generate = True
templates_path = ["_templates"]  # a class page documents its own fields and methods
autodoc_typehints = "none"  # numpydoc's Parameters sections say the types, with units
numpydoc_show_class_members = False
numpydoc_xref_param_type = False

sphinx_gallery_conf = {
    "examples_dirs": str(HERE / "examples"),
    "gallery_dirs": str(HERE / "auto_examples"),
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    # Not a page of the manual: a build must leave the checkout as it found it.
    "write_computation_times": False,
}

html_theme = "pydata_sphinx_theme"
html_title = "inspect-validate"
html_static_path = ["_static"]
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2}

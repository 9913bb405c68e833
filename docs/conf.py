"""Sphinx configuration of the acrobot-mj docs site.

Build (strict: warnings are errors, every cross-reference must resolve):
    .venv/bin/pip install -e '.[docs]'
    .venv/bin/sphinx-build -W --keep-going -n -b html docs docs/_build/html
"""

from __future__ import annotations

import os
import subprocess
import sys

from docutils import nodes
from sphinx.util.docutils import SphinxDirective

import acrobot_mj

project = "acrobot-mj"
author = "acrobot-mj contributors"
copyright = "acrobot-mj contributors, MIT licence"
release = acrobot_mj.__version__
version = release

extensions = ["myst_parser", "sphinx.ext.autodoc"]
source_suffix = {".md": "markdown"}
exclude_patterns = ["_build"]
myst_heading_anchors = 3
myst_enable_extensions = ["dollarmath"]
# Links into the repository outside docs/ (videos, examples, sources) are plain links.
suppress_warnings = ["myst.xref_missing"]

html_theme = "furo"
html_title = f"acrobot-mj {release}"

autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options: dict[str, object] = {}

# No intersphinx: CI reaches only package registries, so no inventory can be fetched. Names from
# other projects (numpy, gymnasium, mujoco, the standard library's typing helpers) stay plain
# text; each pattern below is one such project, nothing of acrobot_mj's own.
nitpick_ignore_regex = [
    ("py:.*", r"(numpy|np)\..*"),
    ("py:.*", r"(gymnasium|gym)(\..*)?"),
    ("py:.*", r"mujoco\..*"),
    ("py:.*", r"casadi\..*"),
    ("py:.*", r"matplotlib\..*"),
    ("py:.*", r"(collections\.abc|concurrent\.futures|typing|types|pathlib|os|abc)\..*"),
]
nitpick_ignore = [
    # Annotations left as text where a module imports matplotlib's Figure only for type checking
    # (acrobot_mj.report.plots), so autodoc cannot evaluate them: pathlib's and matplotlib's.
    ("py:class", "Path"),
    ("py:class", "Figure"),
    # Names imported from gymnasium and mujoco, annotated by their short names.
    ("py:class", "AutoresetMode"),
    ("py:class", "MjModel"),
]
# Gymnasium's own docstrings (reset, step) are Gymnasium's to document.
autodoc_inherit_docstrings = False
# A dataclass without a docstring gets its signature as __doc__: not parsed as a signature.
autodoc_docstring_signature = False


class CommandHelp(SphinxDirective):
    """``acrobot-mj-help``: the usage text of ``acrobot-mj [COMMAND] --help``, run at build time
    so that the page always shows the installed command's options."""

    optional_arguments = 1

    def run(self) -> list[nodes.Node]:
        run = "import sys; from acrobot_mj.cli import main; sys.exit(main(sys.argv[1:]))"
        command = [sys.executable, "-c", run, *self.arguments, "--help"]
        env = {**os.environ, "COLUMNS": "100"}
        text = subprocess.run(command, capture_output=True, text=True, check=True, env=env).stdout
        return [nodes.literal_block(text, text, language="text")]


def setup(app) -> None:
    app.add_directive("acrobot-mj-help", CommandHelp)

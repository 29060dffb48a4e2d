"""Render the report notebook: jupytext source -> executed notebook (papermill) -> HTML (nbconvert)."""

from __future__ import annotations

import subprocess
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import jupytext
import nbformat
import papermill
from nbconvert import HTMLExporter

__all__ = ["OFFLINE_TEMPLATE", "git_commit", "render_notebook"]

#: The HTML template: nbconvert's default, less the scripts it would fetch from CDNs.
OFFLINE_TEMPLATE = Path(__file__).with_name("offline.html.j2")


def git_commit(directory: str | Path) -> str:
    """The checked-out commit of ``directory`` (with ``-dirty`` if it has local changes), or 'unknown'."""
    try:
        result = subprocess.run(
            ["git", "describe", "--always", "--dirty", "--abbrev=12"],
            cwd=directory, capture_output=True, text=True, check=True,
        )  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return result.stdout.strip()


def render_notebook(
    source: str | Path, executed: str | Path, html: str | Path, parameters: Mapping[str, Any], cwd: str | Path = "."
) -> None:
    """Execute the jupytext ``source`` with ``parameters``; write the executed notebook and its HTML.

    The HTML leaves out the code cells (the executed notebook keeps them) and loads
    nothing from the network (:data:`OFFLINE_TEMPLATE`; images are embedded).
    """
    notebook = jupytext.read(source)
    with tempfile.TemporaryDirectory() as tmp:
        unexecuted = Path(tmp) / "report.ipynb"
        nbformat.write(notebook, unexecuted)
        papermill.execute_notebook(
            str(unexecuted), str(executed), parameters=dict(parameters), kernel_name="python3",
            cwd=str(cwd), progress_bar=False,
        )  # fmt: skip
    exporter = HTMLExporter(
        template_file=str(OFFLINE_TEMPLATE), exclude_input=True, exclude_input_prompt=True, exclude_output_prompt=True
    )  # fmt: skip
    body, _ = exporter.from_notebook_node(nbformat.read(executed, as_version=4))
    Path(html).write_text(body)

"""Sphinx extension: MeshCat's viewer JavaScript, shared by every page with a 3D scene.

A recorded :class:`rosbook.viz.Scene` shown in a chapter is a small ``<div>`` plus the
scene's commands; the ~0.85 MB viewer script is not inlined. This extension copies
MeshCat's ``main.min.js`` once into the built book's ``_static/meshcat/`` and adds a
``<script>`` for it to exactly those pages whose body holds a scene, so the browser
downloads (and caches) it once for the whole book.

Enable it in ``_config.yml``: ``sphinx: extra_extensions: [rosbook.sphinx_meshcat]``.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

from sphinx.application import Sphinx

from rosbook.viz import SCENE_CLASS, VIEWER_JS, VIEWER_MODE_VARIABLE, VIEWER_STATIC_NAME


def add_viewer_to_scene_pages(
    app: Sphinx, pagename: str, templatename: str, context: dict[str, Any], doctree: Any
) -> None:
    """Load the shared viewer on a page whose body contains a MeshCat scene."""
    if SCENE_CLASS in context.get("body", ""):
        app.add_js_file(VIEWER_STATIC_NAME)


def copy_viewer(app: Sphinx, exception: Exception | None) -> None:
    """Copy the viewer script (and its licence) into ``_static/meshcat/``."""
    if exception is not None or app.builder.format != "html":
        return
    target = Path(app.outdir) / "_static" / VIEWER_STATIC_NAME
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(VIEWER_JS, target)
    licence = VIEWER_JS.with_name(VIEWER_JS.name + ".LICENSE.txt")
    if licence.exists():
        shutil.copyfile(licence, target.with_name(licence.name))


def setup(app: Sphinx) -> dict[str, Any]:
    # The chapters' kernels start after this and inherit it: their scenes leave the
    # viewer out and rely on the script this extension adds to the page.
    os.environ[VIEWER_MODE_VARIABLE] = "shared"
    app.connect("html-page-context", add_viewer_to_scene_pages)
    app.connect("build-finished", copy_viewer)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}

"""Sphinx extension: the book's 3D scenes, with MeshCat's viewer shared and a still of each.

A recorded :class:`rosbook.viz.Scene` shown in a chapter is a small ``<div>`` plus the
scene's commands; the ~0.85 MB viewer script is not inlined. This extension copies
MeshCat's ``main.min.js`` once into the built book's ``_static/meshcat/`` and adds a
``<script>`` for it to exactly those pages whose body holds a scene, so the browser
downloads (and caches) it once for the whole book.

Each scene also gets a still picture, drawn at build time by headless Chromium
(:mod:`rosbook.book.stills`) into ``_static/scenes/``: shown in the scene's box when
scripts do not run, and in its place in print. A machine without Chromium builds the
book with the scene's description in words instead, and says so in the build log.

Enable it in ``_config.yml``: ``sphinx: extra_extensions: [rosbook.book.sphinx_meshcat]``.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

from sphinx.application import Sphinx
from sphinx.util import logging
from sphinx.util.console import bold, red

from rosbook.book.stills import STYLESHEET, StillCamera, scenes_in, with_still
from rosbook.viz.scene import SCENE_CLASS, VIEWER_JS, VIEWER_MODE_VARIABLE, VIEWER_STATIC_NAME

logger = logging.getLogger(__name__)

#: The scene pages' stylesheet, relative to ``_static``.
STYLESHEET_NAME = "meshcat/scenes.css"
#: Where the stills are written, relative to ``_static``.
STILLS_FOLDER = "scenes"


def add_viewer_to_scene_pages(
    app: Sphinx, pagename: str, templatename: str, context: dict[str, Any], doctree: Any
) -> None:
    """On a page whose body has MeshCat scenes: load the viewer, draw each scene's still."""
    body = context.get("body", "")
    if SCENE_CLASS not in body:
        return
    app.add_js_file(VIEWER_STATIC_NAME)
    app.add_css_file(STYLESHEET_NAME)
    scenes = scenes_in(body)
    camera: StillCamera = app.rosbook_still_camera  # type: ignore[attr-defined]
    stills: dict[str, bytes] = {}
    if scenes and camera.available:
        try:
            stills = camera.draw(scenes)
        except RuntimeError as error:
            _say_loudly(
                f"{pagename}: no still pictures of its 3D scenes ({error}); readers"
                " without JavaScript get each scene's description instead"
            )
    elif scenes:
        _say_loudly(
            f"{pagename}: NO CHROMIUM on this machine (apt-get install chromium): its"
            " 3D scenes get a description in words instead of a still picture"
        )
    folder = Path(app.outdir) / "_static" / STILLS_FOLDER
    for scene in scenes:
        src = None
        if scene.id in stills:
            folder.mkdir(parents=True, exist_ok=True)
            (folder / f"{scene.id}.png").write_bytes(stills[scene.id])
            src = context["pathto"](f"_static/{STILLS_FOLDER}/{scene.id}.png", 1)
        body = body.replace(scene.html, with_still(scene, src))
    context["body"] = body


def _say_loudly(message: str) -> None:
    """A build-log line nobody misses, that does not fail a ``-W`` build."""
    logger.info(bold(red(f"rosbook.book.sphinx_meshcat: {message}")))


def copy_viewer(app: Sphinx) -> None:
    """Copy the viewer script (and its licence) and the scene stylesheet into ``_static``.

    Before the pages are written, so their ``<script>`` gets the file's checksum
    (``?v=...``): a new viewer version is not served from a reader's stale cache.
    """
    if app.builder.format != "html":
        return
    target = Path(app.outdir) / "_static" / VIEWER_STATIC_NAME
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(VIEWER_JS, target)
    licence = VIEWER_JS.with_name(VIEWER_JS.name + ".LICENSE.txt")
    if licence.exists():
        shutil.copyfile(licence, target.with_name(licence.name))
    (Path(app.outdir) / "_static" / STYLESHEET_NAME).write_text(STYLESHEET)


def close_still_camera(app: Sphinx, exception: Exception | None) -> None:
    app.rosbook_still_camera.close()  # type: ignore[attr-defined]


def setup(app: Sphinx) -> dict[str, Any]:
    # The chapters' kernels start after this and inherit it: their scenes leave the
    # viewer out and rely on the script this extension adds to the page.
    os.environ[VIEWER_MODE_VARIABLE] = "shared"
    app.rosbook_still_camera = StillCamera()  # type: ignore[attr-defined]
    app.connect("html-page-context", add_viewer_to_scene_pages)
    app.connect("builder-inited", copy_viewer)
    app.connect("build-finished", close_still_camera)
    return {"version": "1.1", "parallel_read_safe": True, "parallel_write_safe": False}

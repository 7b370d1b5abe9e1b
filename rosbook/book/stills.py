"""Still pictures of a built page's 3D scenes, for readers without JavaScript and for print.

A recorded :class:`rosbook.viz.Scene` is drawn by MeshCat's viewer in the reader's
browser. Where scripts do not run, the box would stay empty; printed, a WebGL canvas may
come out blank. So at build time each scene is drawn once by headless Chromium (the same
viewer, through SwiftShader) and saved as a PNG; the page shows it inside the scene's
box in a ``<noscript>``, and in place of the scene when printed. Its alt text is the
scene's description. Without Chromium a build falls back to that description in words.
"""

from __future__ import annotations

import html
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from rosbook.book.chromium import chromium_path, launch
from rosbook.viz.scene import SCENE_CLASS, VIEWER_JS

#: Class of the still shown in a scene's box when scripts do not run.
STILL_CLASS = "rosbook-scene-still"
#: Class of the still (or description) shown instead of the scene in print.
PRINT_CLASS = "rosbook-scene-print"
#: The page width the stills are drawn at (about the book's text column on a desktop).
STILL_WIDTH = 720
#: Generous: a hang guard for one page's scenes to draw on a loaded machine, not a target.
DRAW_TIMEOUT_MS = 180_000

# One scene as ``Scene.shared_html`` writes it: its box (pane inside), its commands, its
# player script.
_SCENE = re.compile(
    rf'<div class="{SCENE_CLASS}" id="(?P<id>[\w-]+)"(?P<attrs>[^>]*)>'
    r'(?P<pane><div id="(?P=id)-pane"[^>]*></div>)</div>\s*'
    r'<script type="application/json" id="(?P=id)-commands">.*?</script>\s*'
    r"<script>.*?</script>",
    re.S,
)
_LABEL = re.compile(r'aria-label="([^"]*)"')


@dataclass(frozen=True)
class SceneMarkup:
    """One scene found in a page body: its element id, description and HTML."""

    id: str
    description: str
    html: str


def scenes_in(body: str) -> list[SceneMarkup]:
    """The recorded scenes in a page's HTML body, in order."""
    found = []
    for match in _SCENE.finditer(body):
        label = _LABEL.search(match.group("pane"))
        description = html.unescape(label.group(1)) if label else "A 3D scene."
        found.append(SceneMarkup(match.group("id"), description, match.group(0)))
    return found


class StillCamera:
    """Draws scenes to PNGs in one headless Chromium, started at the first picture."""

    def __init__(self, path: str | None = None) -> None:
        self.path = path if path is not None else chromium_path()
        self._launched: Any = None
        self._browser: Any = None

    @property
    def available(self) -> bool:
        return self.path is not None

    def draw(self, scenes: list[SceneMarkup]) -> dict[str, bytes]:
        """A PNG of each scene (by element id), drawn at :data:`STILL_WIDTH` px wide.

        Raises ``RuntimeError`` when Chromium is missing or a scene draws no frame in
        :data:`DRAW_TIMEOUT_MS` (a timeout), ``TimeoutError`` included.
        """
        if not scenes:
            return {}
        if self.path is None:
            raise RuntimeError("no Chromium on this machine (apt-get install chromium)")
        if self._browser is None:
            self._launched = launch(self.path)
            self._browser = self._launched.__enter__()
        page = self._browser.new_page(viewport={"width": STILL_WIDTH, "height": 600})
        try:
            page.set_content(
                "<!DOCTYPE html><html><head><meta charset='utf-8'>"
                f"<script>{VIEWER_JS.read_text()}</script>"
                "<style>body { margin: 0 }</style></head><body>"
                + "\n".join(s.html for s in scenes)
                + "</body></html>",
                wait_until="load",
            )
            stills = {}
            for scene in scenes:
                box = page.locator(f"#{scene.id}")
                try:
                    page.wait_for_function(
                        "id => +(document.getElementById(id).dataset.frames || 0) >= 1",
                        arg=scene.id,
                        timeout=DRAW_TIMEOUT_MS,
                    )
                except Exception as error:  # Playwright's TimeoutError
                    raise RuntimeError(
                        f"timeout: scene {scene.id} drew no frame in {DRAW_TIMEOUT_MS / 1000:.0f} s"
                    ) from error
                # Stop any animation at its first frame (the still is the scene's start),
                # without the control panel.
                page.evaluate(
                    "id => { const v = document.getElementById(id + '-pane').meshcatViewer;"
                    " v.animator.pause(); v.animator.seek(0);"
                    " v.gui.domElement.style.display = 'none'; v.render(); }",
                    scene.id,
                )
                box.scroll_into_view_if_needed()
                stills[scene.id] = box.screenshot(type="png")
            return stills
        finally:
            page.close()

    def close(self) -> None:
        if self._launched is not None:
            self._launched.__exit__(None, None, None)
            self._launched = self._browser = None


@contextmanager
def still_camera() -> Iterator[StillCamera]:
    camera = StillCamera()
    try:
        yield camera
    finally:
        camera.close()


def with_still(scene: SceneMarkup, src: str | None) -> str:
    """``scene``'s HTML with its still: inside the box for no-JS readers, and for print.

    ``src`` is the PNG's URL; None (no picture could be drawn) puts the scene's
    description in words in both places instead.
    """
    alt = html.escape(scene.description, quote=True)
    if src is None:
        still = f'<p class="{STILL_CLASS}">{alt}</p>'
        printed = f'<p class="{PRINT_CLASS}">{alt}</p>'
    else:
        still = f'<img class="{STILL_CLASS}" src="{src}" alt="{alt}">'
        printed = f'<img class="{PRINT_CLASS}" src="{src}" alt="{alt}" loading="lazy">'
    pane_end = scene.html.index("</div></div>") + len("</div>")
    return scene.html[:pane_end] + f"<noscript>{still}</noscript>" + scene.html[pane_end:] + printed


#: The stylesheet for scene pages: stills hidden on screen but in ``<noscript>``, the
#: scene replaced by its still in print.
STYLESHEET = f"""\
.{SCENE_CLASS} noscript .{STILL_CLASS} {{
  position: absolute; inset: 0; width: 100%; height: 100%; object-fit: contain; margin: 0;
}}
p.{STILL_CLASS} {{ padding: 1em; }}
.{PRINT_CLASS} {{ display: none; }}
@media print {{
  .{SCENE_CLASS} {{ display: none !important; }}
  .{PRINT_CLASS} {{ display: block; max-width: 100%; }}
}}
"""

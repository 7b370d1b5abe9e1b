"""Page weight of the built URDF chapter, whose page holds six interactive MeshCat scenes.

Target: under 2 MB for what the page adds beyond the book's theme (its HTML plus the
MeshCat viewer script, which is shared by every page with a scene instead of being
inlined in each). The theme's own assets are loaded by every page of the book and are
reported separately (bench_book measures what a browser transfers).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from benchmarks import Figure
from rosbook.book import pages as bookpages
from rosbook.viz.scene import VIEWER_JS

CHAPTER = "book/urdf_digital_twin"
MB = 1e6


def run() -> list[Figure]:
    with tempfile.TemporaryDirectory(prefix="bench_urdf_") as tmp:
        html = bookpages.build(Path(tmp), [CHAPTER])
        page = html / f"{CHAPTER}.html"
        weight = bookpages.page_weight(page)
        theme = bookpages.page_weight(html / "book" / "intro.html")
        scenes = bookpages.scene_commands(page.read_text())
    own = weight.html + sum(v for k, v in weight.assets.items() if k not in theme.assets)
    return [
        Figure("urdf page: HTML + viewer JS (target < 2 MB)", own / MB, "MB"),
        Figure(f"urdf page: HTML alone ({len(scenes)} scenes)", weight.html / MB, "MB"),
        Figure("urdf page: everything incl. theme assets", weight.total / MB, "MB"),
        Figure("book theme assets on every page", (theme.total - theme.html) / MB, "MB"),
        Figure("shared MeshCat viewer JS (once per book)", VIEWER_JS.stat().st_size / MB, "MB"),
        Figure("scenes on the page", len(scenes), "scenes"),
        Figure(
            "same scenes with the viewer inlined in each",
            (weight.html + len(scenes) * VIEWER_JS.stat().st_size) / MB,
            "MB",
        ),
    ]

"""The Sphinx extensions on a small real project: scene stills, and the site's own MathJax.

Each test builds a two-page Sphinx project with ``python -m sphinx`` (seconds, not the
whole book): a page with a recorded scene and a page with maths.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from rosbook import robots
from rosbook.book.chromium import chromium_path
from rosbook.book.stills import PRINT_CLASS, STILL_CLASS
from rosbook.viz import scene as viz

#: Each test builds a small Sphinx site (and draws in Chromium): out of `make test-fast`.
pytestmark = pytest.mark.slow


def project(tmp_path: Path) -> Path:
    source = tmp_path / "src"
    source.mkdir()
    (source / "conf.py").write_text(
        'extensions = ["rosbook.book.sphinx_meshcat", "rosbook.book.sphinx_site"]\n'
        'html_theme = "sphinx_book_theme"\n'
    )
    scene = viz.show(robots.diff_drive(), camera=(0.9, 0.7, 0.5), height=300).shared_html()
    indented = "\n".join("   " + line for line in scene.splitlines())
    (source / "index.rst").write_text(
        f"Scene\n=====\n\n.. raw:: html\n\n{indented}\n\n.. toctree::\n\n   maths\n"
    )
    (source / "maths.rst").write_text("Maths\n=====\n\n.. math:: v = r \\omega\n")
    return source


def build(source: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    out = source.parent / "html"
    return subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", str(source), str(out)],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
        check=False,
    )


@pytest.mark.skipif(chromium_path() is None, reason="NO BROWSER: install Debian's chromium")
def test_a_scene_gets_a_still_picture_for_no_script_and_print(tmp_path: Path) -> None:
    done = build(project(tmp_path))
    assert done.returncode == 0, done.stderr[-3000:]
    page = (tmp_path / "html" / "index.html").read_text()
    (still,) = re.findall(rf'<img class="{STILL_CLASS}" src="([^"]+)" alt="([^"]+)"', page)
    assert still[1].startswith("3D view of the robot bot")
    png = tmp_path / "html" / still[0]
    assert png.read_bytes().startswith(b"\x89PNG"), "the still is a PNG in _static/scenes"
    assert f'<img class="{PRINT_CLASS}" src="{still[0]}"' in page
    assert page.index("<noscript>") < page.index("</noscript></div>"), "inside the scene box"
    assert (
        "meshcat/scenes.css?v=" in page and (tmp_path / "html/_static/meshcat/scenes.css").is_file()
    )
    assert 'src="_static/meshcat/main.min.js?v=' in page, "the viewer, with its checksum"


def test_without_chromium_the_build_says_so_and_describes_the_scene(tmp_path: Path) -> None:
    # A PATH with Python's folder but no chromium on it.
    env = {**os.environ, "PATH": str(Path(sys.executable).parent)}
    done = build(project(tmp_path), env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "NO CHROMIUM on this machine" in done.stdout + done.stderr
    page = (tmp_path / "html" / "index.html").read_text()
    assert f'<noscript><p class="{STILL_CLASS}">3D view of the robot bot' in page
    assert f'<p class="{PRINT_CLASS}">3D view of the robot bot' in page
    assert "<img" not in page.split("rosbook-meshcat-scene", 1)[1].split("</noscript>")[0]


def test_maths_is_served_by_the_site_and_only_where_there_is_maths(tmp_path: Path) -> None:
    done = build(project(tmp_path), env={**os.environ, "PATH": str(Path(sys.executable).parent)})
    assert done.returncode == 0, done.stderr[-3000:]
    html = tmp_path / "html"
    maths = (html / "maths.html").read_text()
    (src,) = re.findall(r'<script[^>]*src="([^"]*tex-chtml\.js[^"]*)"', maths)
    assert not src.startswith("http"), src
    assert (html / "_static" / "mathjax" / "tex-chtml.js").is_file()
    fonts = list((html / "_static" / "mathjax" / "output" / "chtml" / "fonts").rglob("*.woff"))
    assert fonts, "MathJax's fonts are served too"
    index = (html / "index.html").read_text()
    assert "tex-chtml" not in index, "the page without maths does not load MathJax"
    assert "fontawesome.js" not in index, "no FontAwesome script"
    assert index.count("const THEBE_JS_URL") <= 1
    assert 'data-default-mode="auto"' in index

"""Built book pages: build some chapters alone, weigh a page, read its MeshCat scenes.

Used by the tests and benchmarks that check what a reader's browser receives: the
page's HTML plus every local script, stylesheet and image it loads.
"""

from __future__ import annotations

import base64
import json
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import umsgpack

from rosbook.viz.scene import SCENE_CLASS

ROOT = Path(__file__).resolve().parents[2]


def build(out: Path, chapters: list[str] | None = None, timeout: float = 1800) -> Path:
    """Build the book, or only ``chapters`` (e.g. ``["book/urdf_digital_twin"]``), into ``out``.

    As ``make book`` builds it (``--all -W -n --keep-going``: a warning, a failing or a
    timed-out cell fails it), from a fresh execution cache, in a ROS domain of its own.
    ``chapters`` get a table of contents of their own (the intro plus them). Returns
    the HTML folder; raises ``RuntimeError`` with the end of the log on failure.
    """
    out.mkdir(parents=True, exist_ok=True)
    command = [
        sys.executable, "-m", "rosbook.runtime.isolation", "--",
        str(Path(sys.executable).with_name("jupyter-book")),
        "build", "--all", "-W", "-n", "--keep-going", "--path-output", str(out),
    ]  # fmt: skip
    if chapters is not None:
        toc = out / "_toc.yml"
        entries = "\n".join(f"      - file: {c}" for c in chapters)
        toc.write_text(
            "format: jb-book\nroot: book/intro\nparts:\n  - caption: Chapters\n"
            f"    numbered: true\n    chapters:\n{entries}\n"
        )
        command += ["--toc", str(toc)]
    done = subprocess.run(
        [*command, "."], cwd=ROOT, capture_output=True, text=True, timeout=timeout, check=False
    )
    log = done.stdout + done.stderr
    (out / "build.log").write_text(log)
    if done.returncode != 0:
        raise RuntimeError(
            f"book build failed (exit {done.returncode}); full log: {out / 'build.log'}\n"
            + failure_excerpt(log)
        )
    return out / "_build" / "html"


def failure_excerpt(log: str, context: int = 50) -> str:
    """The failing chapter, its cell and the error from a build log, else the log's end.

    myst-nb's warning names the chapter ("Executing notebook failed", also for a cell
    that timed out or a kernel that died); a cell that raised follows it after nbclient's
    own traceback, as "An error occurred while executing the following cell". Without
    the terminal's colours."""
    lines = re.sub(r"\x1b\[[0-9;]*m", "", log).splitlines()
    failed = next((i for i, ln in enumerate(lines) if "Executing notebook failed" in ln), None)
    cell = next(
        (
            i
            for i, ln in enumerate(lines)
            if "An error occurred while executing the following cell" in ln
            and (failed is None or i > failed)
        ),
        None,
    )
    if cell is not None:
        named = [lines[failed]] if failed is not None else []
        return "\n".join(named + lines[cell : cell + context])
    if failed is not None:
        return "\n".join(lines[failed : failed + context])
    return "\n".join(lines[-60:])


@dataclass(frozen=True)
class PageWeight:
    """What a browser downloads for one page: the HTML and each local asset, in bytes."""

    html: int
    assets: dict[str, int]

    @property
    def total(self) -> int:
        return self.html + sum(self.assets.values())


_ASSET = re.compile(r'<(?:script|img)[^>]*\ssrc="([^"]+)"|<link[^>]*\shref="([^"]+)"', re.I)


def page_weight(page: Path) -> PageWeight:
    """The weight of ``page``: its HTML plus the local scripts, stylesheets, images.

    Remote URLs and links to other pages are not counted; fonts referenced from
    stylesheets are not counted.
    """
    text = page.read_text()
    assets: dict[str, int] = {}
    for match in _ASSET.finditer(text):
        url = match.group(1) or match.group(2)
        tag = match.group(0).lower()
        if match.group(2) and "stylesheet" not in tag and "preload" not in tag:
            continue
        parts = urlsplit(url)
        if parts.scheme or parts.netloc:
            continue
        path = (page.parent / parts.path).resolve()
        if path.is_file():
            assets[parts.path] = path.stat().st_size
    return PageWeight(len(text.encode()), assets)


def scene_commands(page_html: str) -> list[list[dict[str, Any]]]:
    """The MeshCat commands of every scene embedded in a built page, decoded."""
    scenes: list[list[dict[str, Any]]] = []
    pattern = rf'<div class="{SCENE_CLASS}" id="([^"]+)"'
    for element in re.findall(pattern, page_html):
        match = re.search(
            rf'<script type="application/json" id="{element}-commands">(.*?)</script>',
            page_html,
            re.S,
        )
        if match is None:
            raise ValueError(f"scene {element} has no commands")
        packed = json.loads(match.group(1))
        scenes.append([umsgpack.unpackb(base64.b64decode(b)) for b in packed])
    return scenes

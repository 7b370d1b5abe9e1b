"""Sphinx extension: a book site that works offline, weighs little and logs no errors.

- **MathJax from the site itself**: MathJax 3 (from the ``sphinx-mathjax-offline``
  wheel, pinned in requirements.txt) is copied into ``_static/mathjax/`` and pages load
  it from there, not from a CDN: the maths renders with no internet.
- **No FontAwesome script**: pydata-sphinx-theme loads a 1.5 MB script on every page to
  swap its icons for SVG; its stylesheet already draws them from FontAwesome's web fonts
  (tens of kB, fetched once). ``templates/static/webpack-macros.html`` leaves the
  script out.
- **MathJax only where there is maths**: Sphinx loads it (1.2 MB) on the root page too
  when any chapter has maths (the root's table of contents "includes" them).
- **No console errors**: a script the page head would load twice (sphinx-thebe's
  configuration declares ``const THEBE_JS_URL``: twice is a SyntaxError) is loaded once,
  and the theme gets a valid default colour mode ("auto").

Enable it in ``_config.yml``: ``sphinx: extra_extensions: [rosbook.book.sphinx_site]``.
"""

from __future__ import annotations

import shutil
from importlib import metadata
from pathlib import Path
from typing import Any

from sphinx.application import Sphinx
from sphinx.config import Config

#: The wheel that holds MathJax 3's browser files, and where in it they are.
MATHJAX_DISTRIBUTION = "sphinx-mathjax-offline"
MATHJAX_FOLDER = "sphinx-mathjax-offline/static/mathjax"
#: The MathJax build the pages load (TeX in, HTML+CSS out), relative to ``_static``.
MATHJAX_PATH = "mathjax/tex-chtml.js"
#: What of MathJax the site needs beside that file: TeX extensions it loads on demand,
#: its fonts, the menu and accessibility parts (not the other combined builds, not the
#: 4 MB of speech rules).
MATHJAX_PARTS = ["tex-chtml.js", "input/tex", "output/chtml", "a11y", "ui", "adaptors"]
TEMPLATES = Path(__file__).resolve().parent / "templates"


def mathjax_source() -> Path:
    """The folder of MathJax's browser files in the installed wheel."""
    try:
        dist = metadata.distribution(MATHJAX_DISTRIBUTION)
    except metadata.PackageNotFoundError as error:
        raise RuntimeError(
            f"{MATHJAX_DISTRIBUTION} is not installed: `make book` installs requirements.txt"
        ) from error
    folder = Path(str(dist.locate_file(MATHJAX_FOLDER)))
    if not (folder / MATHJAX_PATH.removeprefix("mathjax/")).is_file():
        raise RuntimeError(f"no MathJax in {folder}")
    return folder


def configure(app: Sphinx, config: Config) -> None:
    """Local MathJax, the template without FontAwesome's script, a valid theme mode."""
    mathjax_source()  # fail early, with the reason, if the wheel is missing
    config.mathjax_path = MATHJAX_PATH
    config.templates_path = [*config.templates_path, str(TEMPLATES)]
    context = dict(config.html_context or {})
    context.setdefault("default_mode", "auto")  # pydata-sphinx-theme reads it from here
    config.html_context = context


def load_each_script_once(
    app: Sphinx, pagename: str, templatename: str, context: dict[str, Any], doctree: Any
) -> None:
    """Drop a script the page would load (or run) a second time.

    An extension that adds an inline script after the builder has started gets it in
    twice: once as added (no file name: None), once from Sphinx's registry (file name
    "") - sphinx-thebe's ``const THEBE_JS_URL`` then fails the second time.
    """
    seen: set[tuple[str, tuple[tuple[str, str], ...]]] = set()
    kept = []
    for script in context.get("script_files", []):
        attributes = getattr(script, "attributes", {})
        key = (
            str(getattr(script, "filename", script) or ""),
            tuple(sorted((k, str(v)) for k, v in attributes.items())),
        )
        if key not in seen:
            seen.add(key)
            kept.append(script)
    if not has_maths(context.get("body", "")):
        kept = [s for s in kept if not is_mathjax(s)]
    context["script_files"] = kept


def has_maths(body: str) -> bool:
    """Whether a page body holds anything MathJax would typeset (its ``math`` classes)."""
    return any(marker in body for marker in ('class="math', "mathjax_process", "tex2jax_process"))


def is_mathjax(script: Any) -> bool:
    """MathJax itself, or the inline script that configures it."""
    filename = str(getattr(script, "filename", "") or "")
    body = str(getattr(script, "attributes", {}).get("body", ""))
    return filename.endswith(MATHJAX_PATH) or body.startswith("window.MathJax")


def copy_mathjax(app: Sphinx, exception: Exception | None) -> None:
    if exception is not None or app.builder.format != "html":
        return
    source, target = mathjax_source(), Path(app.outdir) / "_static" / "mathjax"
    for part in MATHJAX_PARTS:
        if (source / part).is_dir():
            shutil.copytree(source / part, target / part, dirs_exist_ok=True)
        else:
            (target / part).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source / part, target / part)


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("config-inited", configure)
    app.connect("html-page-context", load_each_script_once, priority=900)
    app.connect("build-finished", copy_mathjax)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}

"""The built book in a real browser (headless Chromium), served over http with no internet.

Every page opened once at a desktop size, and those with maths or tables once at a
phone's: no console error or warning, no failed request, nothing fetched from another
host, light enough, and no serious or critical violation of axe-core's accessibility
rules. The maths rendered from the site's own MathJax and inside its column;
tables scroll on a phone; plots' text readable. The 3D scenes are tested in
``test_book_scenes.py``.
"""

from __future__ import annotations

import html
import re
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urljoin, urlsplit

import pytest

from rosbook.book.site import visit
from tests.browser import SIZES, axe_violations, pages, scene_pages

MB = 1_000_000
FIRST_PAGE = "book/intro.html"


def _maths_problems(page: object, name: str, width: int) -> list[str]:
    """What is wrong with the maths of an open page: left as TeX, or wider than its column."""
    page.wait_for_function(
        "() => window.MathJax && MathJax.startup && MathJax.startup.promise", timeout=60_000
    )
    page.evaluate("() => MathJax.startup.promise")
    problems = []
    raw = page.eval_on_selector_all(
        ".math", "els => els.filter(e => !e.querySelector('mjx-container')).length"
    )
    if raw:
        problems.append(f"{name}: {raw} formulas left as TeX")
    wide = page.eval_on_selector_all(
        "mjx-container[display='true']",
        "els => els.filter(e => { const p = e.closest('.math') || e.parentElement;"
        " return e.getBoundingClientRect().width > p.getBoundingClientRect().width + 1"
        " && getComputedStyle(e).overflowX === 'visible'; }).length",
    )
    if wide:
        problems.append(f"{name} at {width} px: {wide} equations overflow the column")
    return problems


def _hidden_tables(page: object) -> list[str]:
    """The tables of an open page cut off at its right edge, with no scrolling box."""
    return page.eval_on_selector_all(
        "article table",
        """tables => tables.filter(t => {
            if (t.getBoundingClientRect().right <= window.innerWidth + 1) return false;
            for (let e = t.parentElement; e; e = e.parentElement) {
                const o = getComputedStyle(e).overflowX;
                const scrolls = o === 'auto' || o === 'scroll';
                if (scrolls && e.clientWidth < e.scrollWidth) return false;
            }
            return true;
        }).map(t => t.innerText.slice(0, 40))""",
    )


def _see(built_book: Path, site: str, browser: object, size: str) -> dict[str, Any]:
    """Every page of the book opened once at ``size`` (a phone: the pages with maths or
    tables): what is wrong with each, by test, and what was measured. The tests below
    read what one visit saw; its bytes are counted as the page loaded, before anything
    else was asked of it."""
    found: dict[str, Any] = {
        "loads": [], "bytes": {}, "maths": [], "tables": [], "plots": [], "access": [],
    }  # fmt: skip
    for name in pages(built_book):
        text = (built_book / name).read_text()
        maths, tables = "math notranslate" in text, "<table" in text
        if size == "phone" and not (maths or tables):
            continue
        with visit(browser, site + name, viewport=SIZES[size]) as seen:
            found["bytes"][name] = (seen.total_bytes, _heaviest(seen.transferred))
            if maths:
                found["maths"] += _maths_problems(seen.page, name, SIZES[size]["width"])
                if seen.outside:  # MathJax (its fonts, its extensions) from the site alone
                    found["maths"].append(f"{name}: maths fetched from {seen.outside}")
            if size == "phone" and tables:
                hidden = _hidden_tables(seen.page)
                if hidden:
                    found["tables"].append(f"{name}: tables cut off at 390 px: {hidden}")
            if size == "desktop" and ".png" in text:
                found["plots"] += [(name, *shown) for shown in _plots_shown(seen.page)]
            outside = {"console": seen.console, "failed": seen.failed, "outside": seen.outside}
            for what, items in outside.items():
                found["loads"] += [f"{name} at {size}: {what}: {item}" for item in items]
            if size == "desktop":  # last: axe-core's script is not the page's
                found["access"] += [f"{name}: {said}" for said in axe_violations(seen.page)]
    return found


@pytest.fixture(scope="module")
def desktop(built_book: Path, site: str, browser: object) -> dict[str, Any]:
    return _see(built_book, site, browser, "desktop")


@pytest.fixture(scope="module")
def phone(built_book: Path, site: str, browser: object) -> dict[str, Any]:
    return _see(built_book, site, browser, "phone")


def test_every_page_loads_with_no_console_error_failed_or_outside_request(desktop, phone) -> None:
    problems = desktop["loads"] + phone["loads"]
    assert not problems, "\n".join(problems)


def test_every_page_has_no_serious_or_critical_accessibility_violation(
    built_book: Path, desktop
) -> None:
    scenes = scene_pages(built_book)
    assert scenes, "no page has a 3D scene: its control panel would go unchecked"
    problems = desktop["access"]
    assert not problems, "axe-core:\n" + "\n".join(problems)


_HREF = re.compile(r'<a\s[^>]*href="([^"]+)"')
_ID = re.compile(r'\sid="([^"]+)"')


def test_every_link_and_anchor_resolves(built_book: Path) -> None:
    ids = {p: set(_ID.findall((built_book / p).read_text())) for p in pages(built_book)}
    broken = []
    for name in ids:
        for href in _HREF.findall((built_book / name).read_text()):
            href = html.unescape(href)
            parts = urlsplit(href)
            if parts.scheme or parts.netloc or href.startswith("javascript:"):
                continue
            target = urlsplit(urljoin(name, parts.path)).path if parts.path else name
            path = built_book / unquote(target)
            if path.is_dir():
                path = path / "index.html"
            if not path.is_file():
                broken.append(f"{name}: {href} (no file)")
            elif parts.fragment and path.suffix == ".html":
                if unquote(parts.fragment) not in ids[str(path.relative_to(built_book))]:
                    broken.append(f"{name}: {href} (no anchor)")
    assert not broken, "\n".join(broken)


def test_the_first_page_and_every_scene_page_are_light(built_book: Path, desktop) -> None:
    total, heaviest = desktop["bytes"][FIRST_PAGE]
    assert total <= 1.2 * MB, heaviest
    for name in scene_pages(built_book):
        total, heaviest = desktop["bytes"][name]
        assert total <= 2 * MB, f"{name}: {heaviest}"


def _heaviest(transferred: dict[str, int]) -> str:
    top = sorted(transferred.items(), key=lambda kv: -kv[1])[:8]
    return f"{sum(transferred.values()) / MB:.2f} MB: " + ", ".join(
        f"{u.rsplit('/', 1)[-1]} {b / MB:.2f}" for u, b in top
    )


def test_maths_is_typeset_from_the_site_and_fits_its_column(
    built_book: Path, desktop, phone
) -> None:
    assert any("math notranslate" in (built_book / p).read_text() for p in pages(built_book)), (
        "no page has maths: the test would prove nothing"
    )
    problems = desktop["maths"] + phone["maths"]
    assert not problems, "\n".join(problems)


def test_tables_scroll_rather_than_hide_columns_on_a_phone(phone) -> None:
    assert not phone["tables"], "\n".join(phone["tables"])


# --- figures ---------------------------------------------------------------------------

_IMG = re.compile(r"<img\s[^>]*>")
_ALT = re.compile(r'\salt="([^"]*)"')


def test_every_figure_has_alt_text_saying_what_it_shows(built_book: Path) -> None:
    bad = []
    for name in pages(built_book):
        for tag in _IMG.findall((built_book / name).read_text()):
            alt = _ALT.search(tag)
            text = html.unescape(alt.group(1)) if alt else ""
            if len(text.split()) < 4 or re.search(r"\.(png|svg|jpe?g)\b|[0-9a-f]{32}", text):
                bad.append(f"{name}: {tag[:120]}")
    assert not bad, "figures without a description:\n" + "\n".join(bad)


# The book's plots use matplotlib's default 100 dpi and no text under 10 pt (13.9 px in
# the PNG): shown at 72 % of their size or more, their text is 10 px or more on screen.
MATPLOTLIB_TEXT_PX = 10 * 100 / 72


def _plots_shown(page: object) -> list[tuple[str, int, int]]:
    """Each plot of an open page: its source, its width on the screen and in the PNG."""
    return page.eval_on_selector_all(
        "article .cell_output img[src*='_images/'][src$='.png']",
        "async imgs => { for (const i of imgs) { i.loading = 'eager'; await i.decode(); }"
        " return imgs.map(i => [i.getAttribute('src'), i.clientWidth, i.naturalWidth]); }",
    )


def test_plot_text_is_at_least_10_px_at_1280_px_wide(desktop) -> None:
    plots = desktop["plots"]
    small = [
        f"{name} {src}: shown at {shown} of {natural} px"
        for name, src, shown, natural in plots
        if shown / natural * MATPLOTLIB_TEXT_PX < 10
    ]
    assert plots, "no plot found: the test would prove nothing"
    assert not small, "plots shrunk so their text is under 10 px:\n" + "\n".join(small)

"""The browser the suite's page tests drive is real: it renders a page and has WebGL."""

from __future__ import annotations


def test_chromium_renders_a_page_with_webgl(browser) -> None:
    page = browser.new_page()
    page.set_content("<h1 id=h>ROS</h1><canvas id=c></canvas>")
    assert page.inner_text("#h") == "ROS"
    assert page.evaluate("!!document.getElementById('c').getContext('webgl')")
    page.close()

"""JupyterLab in a real browser, driven as a student drives it: its own commands run a
cell or open a terminal, and the page's own objects say what it shows (the server's page
config must set ``exposeAppInBrowser``). Used by the ``make lab`` and course server tests.
"""

from __future__ import annotations

import json
from typing import Any

#: Bounds against hangs only (a loaded machine is slow; none of them decides a verdict).
START_S = 180
CELL_S = 180

# JupyterLab's own objects (page config `exposeAppInBrowser`): the notebook panel and
# a cell's state, read and driven as its menus and keys would.
PANEL = "window.labNotebook"


def run_cell(page: Any, index: int) -> str:
    """Run cell ``index`` with JupyterLab's run command; return its text and errors."""
    before = page.evaluate(f"{PANEL}.content.widgets[{index}].model.executionCount")
    page.evaluate(
        f"""async () => {{
            const panel = {PANEL};
            window.jupyterapp.shell.activateById(panel.id);
            panel.content.activeCellIndex = {index};
            await window.jupyterapp.commands.execute('notebook:run-cell');
        }}"""
    )
    page.wait_for_function(
        f"""() => {{
            const panel = {PANEL};
            const cell = panel.content.widgets[{index}];
            const count = cell.model.executionCount;
            return count !== null && count !== {json.dumps(before)} &&
                panel.sessionContext.session.kernel.status === 'idle';
        }}""",
        timeout=CELL_S * 1000,
    )
    outputs = page.evaluate(f"{PANEL}.content.widgets[{index}].model.outputs.toJSON()")
    return "".join(
        "".join(o.get("text", "")) + (f"{o['ename']}: {o['evalue']}" if "ename" in o else "")
        for o in outputs
    )


def terminal(page: Any, command: str) -> None:
    """Open a new terminal as a student does (File > New > Terminal), wait until it has the
    keyboard and type ``command`` into it. JupyterLab gives a new terminal the focus once its
    xterm is ready, and it restores the terminals a student left open (a later login shows
    them again): keys typed before then go to another terminal, or split between two."""
    widget = page.evaluate(
        """async () => {
            const widget = await window.jupyterapp.commands.execute('terminal:create-new');
            return widget.id;
        }"""
    )
    keys = page.locator(f"[id='{widget}'] .xterm-helper-textarea")
    # attached first: Playwright's wait_for_function fails at once when its predicate
    # throws, and the one below throws (getElementById is null) until the widget is attached
    keys.wait_for(state="attached", timeout=START_S * 1000)
    page.wait_for_function(
        "id => document.getElementById(id).contains(document.activeElement)",
        arg=widget,
        timeout=START_S * 1000,
    )
    page.keyboard.type(command + "\n")


def wait_for_notebook(page: Any) -> None:
    """Until the open notebook's kernel is idle; it is then ``window.labNotebook``."""
    page.wait_for_function(
        "() => { const p = window.jupyterapp && window.jupyterapp.shell.currentWidget;"
        " const k = p && p.sessionContext && p.sessionContext.session &&"
        " p.sessionContext.session.kernel;"
        " if (k && k.status === 'idle') { window.labNotebook = p; return true; } }",
        timeout=START_S * 1000,
    )


def cell_index(page: Any, text: str) -> int:
    """The first code cell whose source holds ``text``."""
    sources = page.evaluate(
        f"{PANEL}.content.widgets.map(c => c.model.type === 'code' ? c.model.sharedModel.source"
        " : '')"
    )
    return next(i for i, source in enumerate(sources) if text in source)

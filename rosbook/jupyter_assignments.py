"""nbgrader's student side (the Assignments tab and Validate) in a student's server,
imported at the first request that needs it rather than at the server's start.

nbgrader's ``assignment_list`` and ``validate_assignment`` server extensions import all of
nbgrader's applications (nbconvert's exporters, the gradebook's SQLAlchemy, ...) as the
server starts: about 20 MB in every idle student's server (of 150 MB each). This
extension, which ``coursehub.hub.SandboxSpawner`` turns on in their place (the sandbox
sees ``rosbook``, never ``autograder``), routes their URLs to a router that loads both
of them, with their own handlers and settings, the first time a student opens the tab or
validates; from then on nbgrader's handlers answer as they would have from the start.
"""

from __future__ import annotations

import importlib
from typing import Any

from tornado.httputil import HTTPServerRequest
from tornado.routing import Router

#: The server extensions loaded on demand (a student's server has them off).
EXTENSIONS = (
    "nbgrader.server_extensions.assignment_list",
    "nbgrader.server_extensions.validate_assignment",
)
#: Their URLs, under the server's base URL.
PATHS = r"(?:assignments|courses|nbgrader_version)(?:/.*)?$"


class _OnDemand(Router):  # type: ignore[misc]
    """Loads ``EXTENSIONS`` into ``server`` at its first request, then lets them answer."""

    #: No request methods of its own: jupyter_server, which checks that each method of an
    #: added handler authenticates, has none to check here (nbgrader's handlers, which
    #: answer, are checked as they are added).
    SUPPORTED_METHODS = ()

    def __init__(self, server: Any) -> None:
        self.server = server
        self.loaded = False

    def find_handler(self, request: HTTPServerRequest, **kwargs: Any) -> Any:
        if self.loaded:
            return None  # nbgrader's own rules, after this one, answer
        for name in EXTENSIONS:
            importlib.import_module(name)._load_jupyter_server_extension(self.server)
        self.loaded = True
        return self.server.web_app.default_router.find_handler(request)


def _jupyter_server_extension_points() -> list[dict[str, str]]:
    return [{"module": __name__}]


def _load_jupyter_server_extension(server: Any) -> None:
    base_url = server.web_app.settings["base_url"]
    server.web_app.add_handlers(".*$", [(f"{base_url}{PATHS}", _OnDemand(server))])

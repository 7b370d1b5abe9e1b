"""Sphinx extension: the chapters execute side by side, each in a ROS domain of its own.

myst-nb (``execute_notebooks: cache``) executes a chapter while Sphinx reads it, and
jupyter-book's CLI has Sphinx read one chapter at a time. A chapter's cells mostly wait
on ROS (discovery, timers, processes starting), so a build used less than one core of
two. This extension has Sphinx read in parallel processes, as ``sphinx-build -j N``
does, and gives each chapter's kernel a ROS domain of its own: chapters executing at
once never hear each other, and ``ros2 node list`` in a chapter shows that chapter's
nodes only. Pages are still written one at a time (the 3D scenes' stills share one
browser: ``sphinx_meshcat`` is not safe for parallel writing). The chapters' kernels
talk over Unix sockets (``rosbook.runtime.kernels``): a TCP kernel can lose a port to
another process as it starts and the chapter then fails.

Enable it in ``_config.yml``: ``sphinx: extra_extensions: [rosbook.book.sphinx_execute]``.
``ROSBOOK_EXECUTION_JOBS=N make book`` sets how many chapters execute at once (default:
one more than the machine has cores; 1 executes them one at a time).
"""

from __future__ import annotations

import fcntl
import functools
import os
from collections.abc import Callable
from typing import Any

import nbclient
from jupyter_cache import get_cache
from jupyter_cache.cache.main import JupyterCacheBase
from jupyter_cache.executors import utils as cache_executors
from sphinx.application import Sphinx
from sphinx.environment import BuildEnvironment

from rosbook.runtime.isolation import DomainReservation, reserve_domain
from rosbook.runtime.kernels import AsyncUnixSocketKernelManager

#: The domain of the chapter this process reads now (held until its next chapter).
_held: list[DomainReservation] = []


#: The variable that sets how many chapters execute at once.
JOBS_VARIABLE = "ROSBOOK_EXECUTION_JOBS"


def execution_jobs() -> int:
    """How many chapters execute at once."""
    configured = os.environ.get(JOBS_VARIABLE, "")
    if configured:
        if not configured.isdigit() or int(configured) < 1:
            raise ValueError(f"{JOBS_VARIABLE} must be a whole number from 1, not {configured!r}")
        return int(configured)
    return (os.cpu_count() or 1) + 1


#: Extensions jupyter-book loads that do not say whether they are safe for parallel
#: reading, which they are: sphinx-multitoc-numbering only replaces how section numbers
#: are assigned, which Sphinx does in the main process once every chapter is read;
#: sphinx-jupyterbook-latex's transforms change one chapter's tree each, and act for
#: LaTeX builds only.
READ_SAFE = ("sphinx_multitoc_numbering", "sphinx_jupyterbook_latex")


def serialized(write: Callable[..., Any]) -> Callable[..., Any]:
    """jupyter-cache's ``write`` made one at a time across processes (a lock file in the
    cache): adding a record, it deletes those beyond its limit, and one that another
    reader added meanwhile, its notebook not yet written, counts as such ("Notebook file
    does not exist for cache record")."""

    @functools.wraps(write)
    def locked(cache: JupyterCacheBase, *args: Any, **kwargs: Any) -> Any:
        with open(cache.path / "rosbook-write.lock", "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
            return write(cache, *args, **kwargs)

    locked.rosbook_serialized = True  # type: ignore[attr-defined]
    return locked


def read_in_parallel(app: Sphinx) -> None:
    """Once myst-nb has set up: read with the jobs asked for, the cache made ahead."""
    config = getattr(app.env, "mystnb_config", None)
    if config is not None and config.execution_mode == "cache":
        # jupyter-cache makes its folder and database when first used: by two readers
        # at once, one fails ("File exists", "table already exists")
        _ = get_cache(config.execution_cache_path).db
        for name in ("cache_notebook_bundle", "add_nb_to_project"):
            write = getattr(JupyterCacheBase, name)
            if not getattr(write, "rosbook_serialized", False):
                setattr(JupyterCacheBase, name, serialized(write))
        # jupyter-cache executes with nbclient's ``execute`` and its default manager
        cache_executors.executenb = functools.partial(
            nbclient.execute, kernel_manager_class=AsyncUnixSocketKernelManager
        )
    for name in READ_SAFE:
        extension = app.extensions.get(name)
        if extension is not None and extension.parallel_read_safe is None:
            extension.parallel_read_safe = True
    app.rosbook_write_jobs = app.parallel  # type: ignore[attr-defined]
    app.parallel = max(app.parallel, execution_jobs())


def write_as_asked(app: Sphinx, env: BuildEnvironment) -> None:
    """Reading is over: writing gets the jobs the command asked for."""
    app.parallel = app.rosbook_write_jobs  # type: ignore[attr-defined]


def own_domain(app: Sphinx, docname: str, source: list[str]) -> None:
    """Before a chapter is parsed (and so executed): a fresh ROS domain for its kernel.

    Only the domain changes: the run's token (``RUN_MARKER``) stays, so the isolated
    run that started the build still ends whatever a chapter left running."""
    reservation = reserve_domain()
    for previous in _held:
        previous.release()
    _held[:] = [reservation]
    os.environ["ROS_DOMAIN_ID"] = str(reservation.domain_id)


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("builder-inited", read_in_parallel, priority=600)  # after myst-nb's
    app.connect("env-updated", write_as_asked)
    app.connect("source-read", own_domain)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}

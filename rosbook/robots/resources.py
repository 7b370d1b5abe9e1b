"""Where a URDF's file references point: ``package://``, ``file://`` and plain paths.

ROS reads ``package://PKG/rest`` as ``rest`` inside the share folder of the package
``PKG``, found through the ament index on ``AMENT_PREFIX_PATH`` (a sourced workspace's
``install/`` puts its packages there). Here a package need not be installed: a URDF file
on disk also finds its package in the nearest folder above it that holds a
``package.xml`` naming ``PKG`` (the source layout: ``PKG/package.xml``, ``PKG/urdf/``,
``PKG/meshes/``), is named ``PKG``, or has a folder ``PKG`` in it. ``file://`` URIs and
plain paths are taken as they are; a relative one from the URDF file's folder.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import unquote, urlsplit

from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

PACKAGE_SCHEME = "package://"
FILE_SCHEME = "file://"
#: The file that makes a folder a ROS package; its ``<name>`` is the package's name.
PACKAGE_XML = "package.xml"


@dataclass(frozen=True)
class Resolved:
    """Where a URI points: ``path`` when the file exists, else what was tried and why."""

    uri: str
    path: Path | None
    looked: tuple[Path, ...]
    problem: str = ""

    def why(self) -> str:
        """Why the file was not found, as a clause for an error message."""
        if self.problem:
            return self.problem
        return "looked for " + ", ".join(str(p) for p in self.looked)


def package_name(folder: Path) -> str | None:
    """The ``<name>`` in ``folder``'s ``package.xml`` (None without a readable one)."""
    try:
        return (ET.parse(folder / PACKAGE_XML).findtext("name") or "").strip() or None
    except (OSError, ET.ParseError):
        return None


def ament_share(package: str) -> Path | None:
    """``package``'s share folder in the ament index (None when it is not there)."""
    try:
        return Path(get_package_share_directory(package, print_warning=False))
    except (PackageNotFoundError, OSError, ValueError):
        return None


def source_package(package: str, near: Path) -> Path | None:
    """The nearest folder at or above ``near`` that is ``package``'s folder.

    At each level up: the folder itself when its ``package.xml`` names ``package`` or
    it is called ``package``; else a folder ``package`` inside it.
    """
    for folder in (near, *near.parents):
        if folder.name == package or package_name(folder) == package:
            return folder
        if (folder / package).is_dir():
            return folder / package
    return None


def package_folders(package: str, near: Path) -> list[Path]:
    """Folders that may hold ``package``'s files, in the order they are searched."""
    found = [ament_share(package), source_package(package, near)]
    return list(dict.fromkeys(f for f in found if f is not None))


def where_searched(package: str, near: Path) -> str:
    """Where ``package`` was looked for, as a clause for an error message."""
    index = os.environ.get("AMENT_PREFIX_PATH")
    searched = "AMENT_PREFIX_PATH is not set" if not index else f"AMENT_PREFIX_PATH={index}"
    return (
        f"no package {package!r} in the ament index ({searched}) nor a folder with its "
        f"{PACKAGE_XML} at or above {near}"
    )


def resolve(uri: str, base_dir: Path | None = None) -> Resolved:
    """Where ``uri`` (a URDF ``filename``) points; ``base_dir``: the URDF file's folder.

    Without ``base_dir`` (a URDF given as text) relative paths and the package search
    start from the current folder.
    """
    near = (base_dir or Path.cwd()).absolute()
    if uri.startswith(PACKAGE_SCHEME):
        package, _, rest = uri[len(PACKAGE_SCHEME) :].partition("/")
        if not package or not rest.strip("/"):
            return Resolved(uri, None, (), "a package:// URI is package://PACKAGE/path")
        folders = package_folders(package, near)
        if not folders:
            return Resolved(uri, None, (), where_searched(package, near))
        candidates = [folder / rest for folder in folders]
    elif uri.startswith(FILE_SCHEME):
        parts = urlsplit(uri)
        host = "" if parts.netloc in ("", "localhost") else parts.netloc
        candidates = [near / (host + unquote(parts.path)) if host else Path(unquote(parts.path))]
    elif "://" in uri:
        scheme = uri.split("://", 1)[0]
        return Resolved(
            uri, None, (), f"{scheme}:// is not read here; use package://, file:// or a path"
        )
    else:
        candidates = [near / uri]
    for candidate in candidates:
        if candidate.is_file():
            return Resolved(uri, candidate, tuple(candidates))
    return Resolved(uri, None, tuple(candidates))

"""``import rclpy`` wherever pip put the ROS 2 wheels: a venv, a user site, dist-packages.

The ros-jazzy-* wheels install their C libraries as data files, in ``<data>/lib`` (``<data>``
is the venv, ``~/.local`` for ``pip install --user``, ``/usr/local`` for Debian's pip), and
the libraries they vendor in ``site-packages/ros_*.libs``; the RPATHs the wheels carry point
at neither. Their ``ros_wheels_bootstrapper.pth`` fixes that at interpreter start by running
Python again with ``LD_LIBRARY_PATH`` set to ``sys.prefix/lib`` and the ``ros_*.libs`` of
``sys.prefix/lib/pythonX.Y/site-packages``: right in a venv only. In a user site those
folders hold nothing of ROS, and ``import rclpy`` fails with ``librcl_action.so: cannot open
shared object file``. Debian's Python adds a second gap: the wheels' Python code is data of
theirs too, put in ``/usr/local/lib/pythonX.Y/site-packages``, where it does not look (its
folder is ``dist-packages``): ``from rclpy.node import Node`` fails, no module.

:func:`preload` (run by ``import rosbook``, before it imports rclpy) closes both gaps when
``librcl_action.so`` does not load as it is (in a venv, or with a ROS install sourced, it
does nothing). pip's own records (each wheel's RECORD names its files, wherever they went)
give the wheels' library folders and any folder of their Python code that is not on
``sys.path`` (added to it). The dynamic linker reads ``LD_LIBRARY_PATH`` once, at process
start, so for this process a finder loads, before Python loads any extension module, the
wheels' libraries that module needs, dependencies first (read from each library's ELF
``DT_NEEDED`` list), and the type supports of its message package, which rosidl opens by
name later: the dynamic linker then finds each library already loaded, by its name. They
stay local to what needs them (``RTLD_LOCAL``, as with ``LD_LIBRARY_PATH``): the OpenSSL the
wheels vendor must not stand in for Python's own. The processes this one starts get both
folders in ``LD_LIBRARY_PATH`` and ``PYTHONPATH``.
"""

from __future__ import annotations

import ctypes
import importlib.abc
import importlib.machinery
import importlib.metadata
import mmap
import os
import struct
import sys
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType

#: The library ``import rclpy`` fails on first when the wheels' libraries are not found.
PROBE = "librcl_action.so"


def installed_dirs() -> tuple[list[Path], list[Path]]:
    """Where pip put the files of the installed ``ros-*`` distributions, from their RECORDs:
    the folders of their shared libraries (``<data>/lib``, ``site-packages/ros_*.libs``),
    and those of their Python packages that are not where the distribution is recorded
    (Debian records it in ``dist-packages``, the code goes to ``site-packages`` beside it)."""
    libraries: dict[Path, None] = {}
    packages: dict[Path, None] = {}
    for dist in importlib.metadata.distributions():
        if not (dist.metadata["Name"] or "").lower().startswith("ros-"):
            continue
        for file in dist.files or ():
            outside = file.parts[0] == ".."
            if ".so" in file.name and (outside or file.parts[0].endswith(".libs")):
                libraries[Path(dist.locate_file(file)).resolve().parent] = None
            elif outside and file.suffix == ".py" and "site-packages" in file.parts:
                top = Path(*file.parts[: file.parts.index("site-packages") + 1])
                packages[Path(dist.locate_file(top)).resolve()] = None
    return list(libraries), list(packages)


def needed(library: Path) -> list[str]:
    """The names in an ELF64 file's ``DT_NEEDED`` entries: the libraries it links."""
    with library.open("rb") as file, mmap.mmap(file.fileno(), 0, access=mmap.ACCESS_READ) as data:
        if data[:5] != b"\x7fELF\x02":
            return []
        (phoff,) = struct.unpack_from("<Q", data, 0x20)  # the program headers: where,
        phentsize, phnum = struct.unpack_from("<HH", data, 0x36)  # how long, how many
        loads, dynamic = [], (0, 0)
        for i in range(phnum):
            kind, _, offset, vaddr, _, size = struct.unpack_from(
                "<IIQQQQ", data, phoff + i * phentsize
            )
            if kind == 1:  # PT_LOAD: a segment, to turn addresses into file offsets
                loads.append((vaddr, offset, size))
            elif kind == 2:  # PT_DYNAMIC: the dynamic section
                dynamic = (offset, size)
        names, strtab = [], 0
        for at in range(dynamic[0], dynamic[0] + dynamic[1], 16):
            tag, value = struct.unpack_from("<qQ", data, at)
            if tag == 0:  # DT_NULL: the end
                break
            if tag == 1:  # DT_NEEDED: a name's offset in the string table
                names.append(value)
            elif tag == 5:  # DT_STRTAB: the string table's address
                strtab = next(
                    off + value - va for va, off, size in loads if va <= value < va + size
                )
        return [data[strtab + name : data.find(b"\0", strtab + name)].decode() for name in names]


class _Preloader(importlib.abc.MetaPathFinder):
    """Before an extension module loads, loads the wheels' libraries it needs, in order."""

    def __init__(self, dirs: Sequence[Path]) -> None:
        self.files: dict[str, Path] = {}
        for folder in dirs:
            for path in folder.glob("*.so*"):
                self.files.setdefault(path.name, path)
        self.loaded: dict[str, ctypes.CDLL | None] = {}

    def load(self, name: str) -> None:
        """Loads the library ``name`` of the wheels after the libraries it needs."""
        if name in self.loaded or name not in self.files:
            return
        self.loaded[name] = None  # before its dependencies: a cycle stops here
        for dependency in needed(self.files[name]):
            self.load(dependency)
        self.loaded[name] = ctypes.CDLL(str(self.files[name]))

    def find_spec(
        self, fullname: str, path: Sequence[str] | None = None, target: ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or not isinstance(spec.loader, importlib.machinery.ExtensionFileLoader):
            return None  # not an extension module: the usual finders take it
        for dependency in needed(Path(str(spec.origin))):
            self.load(dependency)
        # rosidl opens a message package's type supports by name when a node first uses
        # one of its types: loaded now, they are found among the libraries already in.
        supports = f"lib{fullname.partition('.')[0]}__rosidl_typesupport_"
        for name in [name for name in self.files if name.startswith(supports)]:
            self.load(name)
        return spec


def preload() -> bool:
    """Makes ``import rclpy`` find the wheels' libraries wherever pip put them; returns
    whether they needed it (False in a venv, with ROS sourced, or when called again)."""
    if any(isinstance(finder, _Preloader) for finder in sys.meta_path) or _found_as_is():
        return False
    libraries, packages = installed_dirs()
    if not libraries:
        return False  # no ROS wheels here: rclpy's own error will say so
    on_path = {Path(entry).resolve() for entry in sys.path}
    packages = [folder for folder in packages if folder not in on_path]
    sys.path.extend(map(str, packages))
    # The processes this one starts (a kernel, ``ros2``, a launched node) find it all at
    # their start, as the wheels' bootstrap meant; without ``import rosbook`` too.
    prepend("LD_LIBRARY_PATH", libraries)
    if packages:
        prepend("PYTHONPATH", packages)
    sys.meta_path.insert(0, _Preloader(libraries))
    return True


def _found_as_is() -> bool:
    """Whether the dynamic linker finds ``PROBE`` without help. Where ``LD_LIBRARY_PATH``
    names its folder (a venv's bootstrap, a sourced ROS install) that is a look at the
    folder; loading it to see costs a quarter of a second, and every cold ``ros2``
    command imports this module."""
    for folder in os.environ.get("LD_LIBRARY_PATH", "").split(os.pathsep):
        if folder and os.path.isfile(os.path.join(folder, PROBE)):
            return True
    try:
        ctypes.CDLL(PROBE)
        return True
    except OSError:
        return False


def prepend(variable: str, folders: Sequence[Path]) -> None:
    """Puts ``folders`` first in the search path ``variable`` of this process's environment."""
    rest = [part for part in os.environ.get(variable, "").split(os.pathsep) if part]
    os.environ[variable] = os.pathsep.join([*map(str, folders), *rest])

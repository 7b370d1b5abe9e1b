"""Root's file work in folders a student controls, never through a link.

A student's home, exchange and socket folder are theirs: whatever the hub expects there
(a folder, a file, a socket) they can replace with a symbolic link, at any moment, to
any path of the host, even one that does not exist yet. Everything here works from a
file descriptor of a folder the hub trusts (its own state folder) down, one name at a
time, with calls that refuse a link instead of following it and cannot be raced:
``O_NOFOLLOW`` opens relative to the parent's descriptor (``dir_fd=``), ``fchown`` on
what was opened, new files written under a name of their own and renamed into place
(a rename replaces a link, never writes through it), copies read from descriptors
checked to be regular files. What is refused raises ``Refused``, which names the path
and what was found there; the hub logs it and goes on with the other students.
"""

from __future__ import annotations

import errno
import os
import secrets
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

#: How a folder is opened: only a real folder, never a link to one.
FOLDER = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC
#: How a file is read: a link is refused, a FIFO does not block (then fstat refuses it).
READ = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
#: How a new file is made: never over anything, never through a link.
NEW = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC
CHUNK = 1 << 16


class Refused(Exception):
    """Something other than what the hub works on (a link, a device, a file too large)
    was found at a student's path: named, never followed."""

    def __init__(self, path: str | os.PathLike[str], found: str) -> None:
        super().__init__(f"{path}: {found}; refused, never followed")


def _found(dir_fd: int, name: str) -> str:
    """What is at ``name`` (for the refusal's message), without following it."""
    try:
        st = os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
    except OSError as exc:
        return os.strerror(exc.errno or 0)
    if stat.S_ISLNK(st.st_mode):
        return f"a symbolic link to {os.readlink(name, dir_fd=dir_fd)}"
    return _kind(st.st_mode)


def _kind(mode: int) -> str:
    for test, what in (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISREG, "a regular file"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
    ):
        if test(mode):
            return what
    return "not a file"


def open_folder(dir_fd: int, name: str, path: str | os.PathLike[str]) -> int:
    """A descriptor of the folder ``name`` in ``dir_fd`` (``path`` names it in errors);
    ``Refused`` if it is a link or not a folder."""
    try:
        return os.open(name, FOLDER, dir_fd=dir_fd)
    except OSError as exc:
        if exc.errno in (errno.ELOOP, errno.ENOTDIR):
            raise Refused(path, _found(dir_fd, name)) from None
        raise


@contextmanager
def folder(
    root: str | os.PathLike[str],
    *parts: str,
    create: bool = False,
    owner: tuple[int, int] | None = None,
) -> Iterator[int]:
    """A descriptor of ``root/parts...``, each part opened without following a link.

    ``root`` is the hub's own (trusted); each of ``parts`` may be a student's. With
    ``create``, missing folders are made, and given to ``owner`` (uid, gid) if set.
    """
    fd = os.open(root, FOLDER)
    path = Path(root)
    try:
        for part in parts:
            path = path / part
            made = False
            if create:
                try:
                    os.mkdir(part, 0o755, dir_fd=fd)
                    made = True
                except FileExistsError:
                    pass
            child = open_folder(fd, part, path)
            os.close(fd)
            fd = child
            if made and owner is not None:
                os.fchown(fd, *owner)
        yield fd
    finally:
        os.close(fd)


def give(fd: int, owner: tuple[int, int] | None) -> None:
    """Give the opened ``fd`` (never a path) to ``owner``, if set."""
    if owner is not None:
        os.fchown(fd, *owner)


def write(
    dir_fd: int,
    name: str,
    data: bytes,
    path: str | os.PathLike[str],
    owner: tuple[int, int] | None = None,
) -> None:
    """``data`` as the file ``name`` in ``dir_fd``: written under a fresh name, then
    renamed over ``name`` (a link there is replaced, never written through)."""
    fresh = f".{name}.{secrets.token_hex(8)}"
    create(dir_fd, fresh, data, Path(path).with_name(fresh), owner)
    try:
        os.rename(fresh, name, src_dir_fd=dir_fd, dst_dir_fd=dir_fd)
    except OSError:
        os.unlink(fresh, dir_fd=dir_fd)
        raise Refused(path, _found(dir_fd, name)) from None


def create(
    dir_fd: int,
    name: str,
    data: bytes,
    path: str | os.PathLike[str],
    owner: tuple[int, int] | None = None,
) -> bool:
    """Create the file ``name`` in ``dir_fd`` with ``data`` unless something is there
    (False); a link there, even a dangling one, is ``Refused``, never created through."""
    try:
        fd = os.open(name, NEW, 0o644, dir_fd=dir_fd)
    except FileExistsError:
        if stat.S_ISLNK(os.stat(name, dir_fd=dir_fd, follow_symlinks=False).st_mode):
            raise Refused(path, _found(dir_fd, name)) from None
        return False
    try:
        with os.fdopen(fd, "wb", closefd=False) as out:
            out.write(data)
        give(fd, owner)
    finally:
        os.close(fd)
    return True


def remove_tree(dir_fd: int, name: str, path: str | os.PathLike[str]) -> None:
    """Delete the folder ``name`` in ``dir_fd`` and what it holds (nothing if missing);
    a link there is ``Refused``: never followed, never deleted through. Links inside
    are deleted themselves, as files are."""
    try:
        st = os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
    except FileNotFoundError:
        return
    if not stat.S_ISDIR(st.st_mode):
        raise Refused(path, _found(dir_fd, name))
    fd = open_folder(dir_fd, name, path)
    try:
        with os.scandir(fd) as entries:
            inside = [(entry.name, entry.is_dir(follow_symlinks=False)) for entry in entries]
        for child, is_folder in inside:
            if is_folder:
                remove_tree(fd, child, Path(path) / child)
            else:
                os.unlink(child, dir_fd=fd)
    finally:
        os.close(fd)
    os.rmdir(name, dir_fd=dir_fd)


def copy_in(
    source: Path, dir_fd: int, name: str, path: Path, owner: tuple[int, int] | None = None
) -> None:
    """Copy the hub's folder ``source`` as the new folder ``name`` in ``dir_fd`` (a
    student's), every folder and file given to ``owner``."""
    try:
        os.mkdir(name, 0o755, dir_fd=dir_fd)
    except FileExistsError:
        raise Refused(path, _found(dir_fd, name)) from None
    fd = open_folder(dir_fd, name, path)
    try:
        give(fd, owner)
        for entry in sorted(source.iterdir()):
            if entry.is_symlink():
                continue  # the hub's own folder holds none; never copied as one
            if entry.is_dir():
                copy_in(entry, fd, entry.name, path / entry.name, owner)
            elif entry.is_file():
                write(fd, entry.name, entry.read_bytes(), path / entry.name, owner)
    finally:
        os.close(fd)


def read(dir_fd: int, name: str, path: str | os.PathLike[str], limit: int) -> bytes:
    """The regular file ``name`` in ``dir_fd``, at most ``limit`` bytes (``Refused``
    past it, or if it is a link, a FIFO or a device)."""
    return b"".join(_chunks(dir_fd, name, path, limit))


def _chunks(dir_fd: int, name: str, path: str | os.PathLike[str], limit: int) -> Iterator[bytes]:
    try:
        fd = os.open(name, READ, dir_fd=dir_fd)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise Refused(path, _found(dir_fd, name)) from None
        raise
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise Refused(path, _kind(mode))
        seen = 0
        while chunk := os.read(fd, CHUNK):
            seen += len(chunk)
            if seen > limit:  # counted while reading: a file that grows is stopped too
                raise Refused(path, f"more than {limit} bytes")
            yield chunk
    finally:
        os.close(fd)


def copy_out(dir_fd: int, path: Path, target: Path, limit: int) -> int:
    """Copy a student's folder (``dir_fd``, named ``path``) into the hub's new folder
    ``target``: regular files and folders only, at most ``limit`` bytes in all (counted
    while copying). ``Refused`` at the first link, FIFO, device or byte past the limit;
    the bytes copied otherwise."""
    target.mkdir()
    used = 0
    with os.scandir(dir_fd) as entries:
        names = sorted(entry.name for entry in entries)
    for name in names:
        st = os.stat(name, dir_fd=dir_fd, follow_symlinks=False)
        if stat.S_ISDIR(st.st_mode):
            fd = open_folder(dir_fd, name, path / name)
            try:
                used += copy_out(fd, path / name, target / name, limit - used)
            finally:
                os.close(fd)
        elif stat.S_ISREG(st.st_mode):
            with (target / name).open("xb") as out:
                for chunk in _chunks(dir_fd, name, path / name, limit - used):
                    out.write(chunk)
                    used += len(chunk)
        else:
            raise Refused(path / name, _found(dir_fd, name))
    return used


def clone(source: int, into: int, path: Path, owner: tuple[int, int] | None) -> None:
    """Copy a student's folder (``source``, named ``path``) into the hub's ``into``:
    folders, regular files, and links as links (never followed), all given to
    ``owner``; FIFOs, sockets and devices are left out."""
    with os.scandir(source) as entries:
        names = sorted(entry.name for entry in entries)
    for name in names:
        mode = os.stat(name, dir_fd=source, follow_symlinks=False).st_mode
        if stat.S_ISDIR(mode):
            os.mkdir(name, 0o755, dir_fd=into)
            inner, outer = open_folder(source, name, path / name), open_folder(into, name, name)
            try:
                give(outer, owner)
                clone(inner, outer, path / name, owner)
            finally:
                os.close(inner)
                os.close(outer)
        elif stat.S_ISLNK(mode):
            os.symlink(os.readlink(name, dir_fd=source), name, dir_fd=into)
            if owner is not None:
                os.chown(name, *owner, dir_fd=into, follow_symlinks=False)
        elif stat.S_ISREG(mode):
            fd = os.open(name, NEW, 0o644, dir_fd=into)
            try:
                for chunk in _chunks(source, name, path / name, limit=1 << 62):
                    os.write(fd, chunk)  # short writes: none on a local disk's file
                give(fd, owner)
            finally:
                os.close(fd)

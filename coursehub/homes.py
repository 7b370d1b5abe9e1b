"""Each student's home as a file system of its own: its size is their disk quota.

A home is an ext4 image (``IMAGES/NAME.ext4``, in a folder only root can open),
loop-mounted over the student's home folder while their server runs. At the limit,
writes fail with ENOSPC ("No space left on device"), which JupyterLab's save shows;
the student's server, and everyone else's disk, go on. The sandbox sees a device
(``/dev/loopN``) at ``/home/student`` in its mountinfo, never a host folder.

The image is made at the student's first start, with what their home held then copied
in (folders, regular files and links as links, never followed). Mounting needs root,
``mount`` and ``mkfs.ext4`` (e2fsprogs) and loop devices; ``available`` says why not.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

from coursehub import safefs

#: Mount options of a home: no set-uid programs or device files from a student's disk.
OPTIONS = "loop,nosuid,nodev"
#: A hang guard for mkfs, mount and umount (a loaded machine is slow).
TIMEOUT = 120.0


def available() -> str | None:
    """Why homes cannot be file systems of their own here, or None."""
    if os.geteuid() != 0:
        return "the hub is not root (mounting a home needs root)"
    missing = [tool for tool in ("mkfs.ext4", "mount", "umount") if shutil.which(tool) is None]
    if missing:
        return f"{', '.join(missing)} not found (Debian: apt-get install e2fsprogs mount)"
    if not os.path.exists("/dev/loop-control"):
        return "no loop devices (/dev/loop-control)"
    return None


def _run(*argv: str) -> None:
    done = subprocess.run(argv, capture_output=True, text=True, timeout=TIMEOUT)
    if done.returncode != 0:
        raise OSError(f"{' '.join(argv)}: {(done.stderr or done.stdout).strip()}")


def mount(home: Path, image: Path, size: int, owner: tuple[int, int]) -> None:
    """Mount ``image`` (made first if missing: ``size`` bytes, its root ``owner``'s,
    holding what ``home`` held) over ``home``; nothing if ``home`` is mounted already."""
    if os.path.ismount(home):
        return
    image.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    if not image.exists():
        _make(home, image, size, owner)
    _run("mount", "-o", OPTIONS, str(image), str(home))


def _make(home: Path, image: Path, size: int, owner: tuple[int, int]) -> None:
    fresh = image.with_name(f".{image.name}.new")
    with fresh.open("wb") as out:
        out.truncate(size)  # sparse: the disk is used as the student writes
    uid, gid = owner
    _run("mkfs.ext4", "-q", "-F", "-m", "0", "-E", f"root_owner={uid}:{gid}", str(fresh))
    staging = image.with_name(f".{image.stem}.staging")
    staging.mkdir(mode=0o700, exist_ok=True)
    _run("mount", "-o", OPTIONS, str(fresh), str(staging))
    try:
        with safefs.folder(staging) as into:
            os.rmdir("lost+found", dir_fd=into)  # root's, in the student's sight otherwise
            with safefs.folder(home) as old:
                safefs.clone(old, into, home, owner)
    except OSError as exc:
        fresh.unlink()
        raise OSError(f"{home} does not fit in a home of {size >> 20} MB: {exc}") from exc
    finally:
        _run("umount", str(staging))
        staging.rmdir()
    fresh.rename(image)


def unmount(home: Path) -> None:
    """Unmount the student's home (lazily if something still holds it)."""
    if os.path.ismount(home):
        try:
            _run("umount", str(home))
        except OSError:
            _run("umount", "--lazy", str(home))

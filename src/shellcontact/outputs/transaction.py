"""An output directory replaced whole or not at all.

A run writes into a staging directory beside its target (``.DIR.staging-<pid>-<token>``, the same
filesystem) and moves it into place only when every file is complete: a rename, or over an
existing directory an atomic exchange of the two (Linux ``renameat2(RENAME_EXCHANGE)``; elsewhere
a rename aside and a rename in, which the next run undoes if it was cut between the two), after
which the old one is deleted. At every instant the target holds either the previous or the new
complete result. A lock file beside the target (``.DIR.lock``, ``flock``) keeps two runs out of
the same directory; staging directories whose process is gone are removed by the next run.

Deleting never descends into another filesystem (``remove_tree``): a target that holds a mount point
is committed entry by entry, so the mount stays where it is and its files are never touched. Once the
new result is in place, a failure to delete the previous one is a warning, never a failed run.

``replace_dir(target, overwrite=..., owned=...)`` is the whole transaction as a context manager;
``DirectoryLock``, ``remove_stale`` and ``Staging`` are its parts (a resumable sweep uses them
separately).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import logging
import os
import re
import secrets
import shutil
from collections.abc import Collection, Iterator
from pathlib import Path

from ..errors import InputError
from .files import check_output_dir, expand_user

log = logging.getLogger("shellcontact")
_STAGING = re.compile(r"\.(?P<name>.+)\.(?P<kind>staging|old)-(?P<pid>\d+)-[0-9a-f]+$")


def resolve_target(path: str | Path) -> Path:
    """The real path of an output directory (a symbolic link is replaced at its destination)."""
    return Path(os.path.realpath(expand_user(path)))


def _mount_points() -> set[str]:
    """Every mount point of this process (Linux ``/proc/self/mountinfo``; empty elsewhere)."""
    try:
        text = Path("/proc/self/mountinfo").read_text()
    except OSError:
        return set()
    # field 5 is the mount point, with space, tab, newline and backslash written as octal escapes
    unescape = re.compile(r"\\([0-7]{3})")
    return {unescape.sub(lambda m: chr(int(m[1], 8)), line.split()[4]) for line in text.splitlines()
            if len(line.split()) > 4}


def mounts_below(path: str | Path) -> list[str]:
    """The mount points strictly inside ``path`` (bind mounts of the same filesystem too)."""
    root = os.path.realpath(path).rstrip("/") + "/"
    return sorted(m for m in _mount_points() if m.startswith(root))


def remove_tree(path: str | Path) -> list[str]:
    """Delete ``path`` and what it holds, never descending into another filesystem: a mount point (or a
    directory on another device) inside is left, with the directories that lead to it. Returns what was
    left; a symbolic link is removed, never followed."""
    path = str(path)
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return []
    if not os.path.isdir(path) or os.path.islink(path):
        os.unlink(path)
        return []
    mounts = set(mounts_below(path))
    left: list[str] = []

    def walk(directory: str) -> bool:  # True when emptied and removed
        whole = True
        with os.scandir(directory) as entries:
            for entry in entries:
                if entry.is_dir(follow_symlinks=False):
                    if entry.path in mounts or entry.stat(follow_symlinks=False).st_dev != st.st_dev:
                        left.append(entry.path)
                        whole = False
                    else:
                        whole = walk(entry.path) and whole
                else:
                    with contextlib.suppress(FileNotFoundError):
                        os.unlink(entry.path)
        if whole:
            os.rmdir(directory)
        return whole

    if os.path.realpath(path) in _mount_points():
        return [path]
    walk(path)
    return left


def _remove_quietly(path: str | Path, what: str) -> None:
    """``remove_tree`` after the result is committed: what cannot go is reported, never raised."""
    try:
        left = remove_tree(path)
    except OSError as exc:
        log.warning("the %s %s could not be deleted (%s); delete it by hand", what, path, exc.strerror or exc)
        return
    if left:
        log.warning("the %s %s was kept: it holds another filesystem (%s); unmount it, then delete the "
                    "directory by hand", what, path, ", ".join(left[:3]))


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return False  # our own leftovers: under the lock nothing else of ours writes this target
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class DirectoryLock:
    """``flock`` on ``.DIR.lock`` beside ``target``: a second run refuses (exit 2) or, with ``wait``, waits."""

    def __init__(self, target: str | Path, *, wait: bool = False, shown: str | Path | None = None,
                 option: str = "--output") -> None:
        self.target = resolve_target(target)
        self.path = self.target.parent / f".{self.target.name}.lock"
        self.wait = wait
        self.shown = str(shown if shown is not None else target)
        self.option = option
        self.fd: int | None = None

    def __enter__(self) -> DirectoryLock:
        self.target.parent.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)  # an OSError names the lock file
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | (0 if self.wait else fcntl.LOCK_NB))
            except BlockingIOError:
                holder = os.read(fd, 32).decode(errors="replace").strip() or "?"
                os.close(fd)
                raise InputError(self.option, f"{self.shown!r} is being written by another shellcontact run "
                                              f"(pid {holder}); wait for it to finish, or add --wait") from None
            except BaseException:
                os.close(fd)
                raise
            # the holder we waited for removes the file as it leaves: lock the file now at that path
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        try:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
        except OSError as exc:  # e.g. a full disk: the first file written, named
            os.close(fd)
            raise OSError(exc.errno, exc.strerror, str(self.path)) from None
        self.fd = fd
        return self

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            self.path.unlink(missing_ok=True)  # still holding the lock: a waiter re-checks the inode
            os.close(self.fd)
            self.fd = None


def stale_stagings(target: str | Path) -> list[Path]:
    """The staging directories of runs into ``target`` whose process is gone (call under the lock)."""
    target = resolve_target(target)
    out = []
    for entry in sorted(target.parent.glob(f".{_glob_escape(target.name)}.staging-*-*")):
        m = _STAGING.match(entry.name)
        if m is not None and m["name"] == target.name and not _pid_alive(int(m["pid"])):
            out.append(entry)
    return out


def remove_stale(target: str | Path, keep: Path | None = None) -> None:
    """Remove the staging directories of runs into ``target`` whose process is gone (call under the lock),
    but ``keep`` (one a study takes over: ``Staging.adopt``).

    A previous result left aside by a run cut between its two renames is put back first.
    """
    target = resolve_target(target)
    for entry in sorted(target.parent.glob(f".{_glob_escape(target.name)}.*-*-*")):
        m = _STAGING.match(entry.name)
        if m is None or m["name"] != target.name or _pid_alive(int(m["pid"])) or entry == keep:
            continue
        if m["kind"] == "old" and not os.path.lexists(target):
            os.rename(entry, target)
        else:
            with contextlib.suppress(OSError):
                remove_tree(entry)


def _glob_escape(name: str) -> str:
    return re.sub(r"([*?\[])", r"[\1]", name)


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux renameat2 RENAME_EXCHANGE); False where that is not available."""
    import ctypes

    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _link_tree(src: Path, dst: Path) -> None:
    """Put a copy of ``src`` at ``dst``: hard links where possible (the same filesystem), else copies."""

    def link(s: str, d: str) -> None:
        try:
            os.link(s, d)
        except OSError:
            shutil.copy2(s, d)

    if src.is_symlink() or not src.is_dir():
        if src.is_symlink():
            os.symlink(os.readlink(src), dst)
        else:
            link(str(src), str(dst))
    else:
        shutil.copytree(src, dst, symlinks=True, copy_function=link)


class Staging:
    """A directory ``.DIR.staging-<pid>-<token>`` beside ``target``: ``create`` makes it, ``commit`` moves it
    into place, ``discard`` removes it. The object exists before the directory does, so that a caller holds
    it before ``create`` and can always discard: a signal that lands just after the mkdir (a test sends
    SIGINT the moment the directory appears) would otherwise leave it behind, its owner never assigned."""

    def __init__(self, target: str | Path) -> None:
        self.target = resolve_target(target)
        self.path = self.target.parent / f".{self.target.name}.staging-{os.getpid()}-{secrets.token_hex(4)}"

    def create(self) -> Staging:
        self.path.mkdir(parents=True)
        return self

    def adopt(self, stale: Path) -> Staging:
        """Take over ``stale``, the staging directory of an interrupted run (its finished work kept)."""
        os.rename(stale, self.path)
        return self

    def commit(self, owned: Collection[str]) -> None:
        """Move the staged directory to the target.

        Entries of an existing target that the run does not own (``owned``: the names it writes) and
        did not stage are carried over, so a user's own files survive ``--force``.
        """
        target = self.target
        if not os.path.lexists(target):
            os.rename(self.path, target)
            return
        if Path.cwd() == target or target in Path.cwd().parents or mounts_below(target):
            # a directory in use as the working directory stays where it is; one holding a mount point too
            # (a swap would carry the mount into the previous result, deleted next)
            self._commit_entries(owned)
            return
        for entry in target.iterdir():
            if entry.name not in owned and not os.path.lexists(self.path / entry.name):
                _link_tree(entry, self.path / entry.name)
        if _exchange(self.path, target):
            _remove_quietly(self.path, "previous result")  # committed: a leftover is a warning
        else:
            aside = target.parent / f".{target.name}.old-{os.getpid()}-{secrets.token_hex(4)}"
            os.rename(target, aside)
            os.rename(self.path, target)
            _remove_quietly(aside, "previous result")

    def _commit_entries(self, owned: Collection[str]) -> None:
        """Entry by entry (each atomic, not the set): only when the target cannot be swapped."""
        for name in owned:
            staged, dst = self.path / name, self.target / name
            if os.path.lexists(staged):
                mount = os.path.realpath(dst) in _mount_points()
                if staged.is_dir() and dst.is_dir() and not dst.is_symlink() and not mount and _exchange(staged, dst):
                    continue
                if dst.is_dir() and not dst.is_symlink():
                    if remove_tree(dst):
                        raise OSError(errno.EBUSY, "it holds another filesystem (a mount point); unmount it or "
                                      "write elsewhere", str(dst))
                os.replace(staged, dst)
            elif dst.is_dir() and not dst.is_symlink():
                remove_tree(dst)  # the previous run's, not written this time (a mount inside stays)
            else:
                dst.unlink(missing_ok=True)
        self.discard()

    def discard(self) -> None:
        with contextlib.suppress(OSError):
            remove_tree(self.path)


@contextlib.contextmanager
def replace_dir(target: str | Path, *, overwrite: bool, owned: Collection[str], wait: bool = False,
                option: str = "--output") -> Iterator[Path]:
    """Lock ``target``, check it may be written, and yield a staging directory that replaces it on success.

    A non-empty target is refused unless ``overwrite``. On any exception (including
    KeyboardInterrupt) the staging directory is removed and the target is left as it was.
    """
    target = expand_user(target)  # one path, checked and written (a "~" the shell left unexpanded)
    check_output_dir(target, overwrite, option)  # refuse at once, before waiting for a lock
    with DirectoryLock(target, wait=wait, shown=target, option=option):
        remove_stale(target)
        check_output_dir(target, overwrite, option)
        stage = Staging(target)
        try:
            stage.create()
            yield stage.path
            stage.commit(owned)
        except OSError as exc:
            stage.discard()
            name_in_target(exc, stage.path, target)
            raise
        except BaseException:
            stage.discard()
            raise


def name_in_target(exc: OSError, staged: Path, target: str | Path) -> None:
    """Name the file by its place in the target (``DIR/fields.vtu``), not in the staging directory."""
    name = str(exc.filename) if exc.filename is not None else ""
    if name.startswith(str(staged)):
        exc.filename = str(Path(target)) + name[len(str(staged)):]

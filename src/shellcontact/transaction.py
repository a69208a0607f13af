"""An output directory replaced whole or not at all.

A run writes into a staging directory beside its target (``.DIR.staging-<pid>-<token>``, the same
filesystem) and moves it into place only when every file is complete: a rename, or over an
existing directory an atomic exchange of the two (Linux ``renameat2(RENAME_EXCHANGE)``; elsewhere
a rename aside and a rename in, which the next run undoes if it was cut between the two), after
which the old one is deleted. At every instant the target holds either the previous or the new
complete result. A lock file beside the target (``.DIR.lock``, ``flock``) keeps two runs out of
the same directory; staging directories whose process is gone are removed by the next run.

``replace_dir(target, overwrite=..., owned=...)`` is the whole transaction as a context manager;
``DirectoryLock``, ``remove_stale`` and ``Staging`` are its parts (a resumable sweep uses them
separately).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import re
import secrets
import shutil
from collections.abc import Collection, Iterator
from pathlib import Path

from .errors import InputError
from .files import check_output_dir

_STAGING = re.compile(r"\.(?P<name>.+)\.(?P<kind>staging|old)-(?P<pid>\d+)-[0-9a-f]+$")


def resolve_target(path: str | Path) -> Path:
    """The real path of an output directory (a symbolic link is replaced at its destination)."""
    return Path(os.path.realpath(Path(path).expanduser()))


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
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
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
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self.fd = fd
        return self

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            self.path.unlink(missing_ok=True)  # still holding the lock: a waiter re-checks the inode
            os.close(self.fd)
            self.fd = None


def remove_stale(target: str | Path) -> None:
    """Remove the staging directories of runs into ``target`` whose process is gone (call under the lock).

    A previous result left aside by a run cut between its two renames is put back first.
    """
    target = resolve_target(target)
    for entry in sorted(target.parent.glob(f".{_glob_escape(target.name)}.*-*-*")):
        m = _STAGING.match(entry.name)
        if m is None or m["name"] != target.name or _pid_alive(int(m["pid"])):
            continue
        if m["kind"] == "old" and not os.path.lexists(target):
            os.rename(entry, target)
        else:
            shutil.rmtree(entry, ignore_errors=True)


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

    def commit(self, owned: Collection[str]) -> None:
        """Move the staged directory to the target.

        Entries of an existing target that the run does not own (``owned``: the names it writes) and
        did not stage are carried over, so a user's own files survive ``--force``.
        """
        target = self.target
        if not os.path.lexists(target):
            os.rename(self.path, target)
            return
        if Path.cwd() == target or target in Path.cwd().parents:
            self._commit_entries(owned)  # a directory in use as the working directory stays where it is
            return
        for entry in target.iterdir():
            if entry.name not in owned and not os.path.lexists(self.path / entry.name):
                _link_tree(entry, self.path / entry.name)
        if _exchange(self.path, target):
            shutil.rmtree(self.path)  # now the previous result
        else:
            aside = target.parent / f".{target.name}.old-{os.getpid()}-{secrets.token_hex(4)}"
            os.rename(target, aside)
            os.rename(self.path, target)
            shutil.rmtree(aside)

    def _commit_entries(self, owned: Collection[str]) -> None:
        """Entry by entry (each atomic, not the set): only when the target cannot be swapped."""
        for name in owned:
            staged, dst = self.path / name, self.target / name
            if os.path.lexists(staged):
                if staged.is_dir() and dst.is_dir() and not dst.is_symlink() and _exchange(staged, dst):
                    continue
                if dst.is_dir() and not dst.is_symlink():
                    shutil.rmtree(dst)
                os.replace(staged, dst)
            elif dst.is_dir() and not dst.is_symlink():
                shutil.rmtree(dst)  # the previous run's, not written this time
            else:
                dst.unlink(missing_ok=True)
        self.discard()

    def discard(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)


@contextlib.contextmanager
def replace_dir(target: str | Path, *, overwrite: bool, owned: Collection[str], wait: bool = False,
                option: str = "--output") -> Iterator[Path]:
    """Lock ``target``, check it may be written, and yield a staging directory that replaces it on success.

    A non-empty target is refused unless ``overwrite``. On any exception (including
    KeyboardInterrupt) the staging directory is removed and the target is left as it was.
    """
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

"""The command line's console: messages on stdout (silenced by --quiet), a progress bar on stderr, and the
logging set-up (stderr, and the --log file, which names itself and stops quietly when its disk fills up).

Only the standard library is imported here (``shellcontact --help`` stays light).
"""

from __future__ import annotations

import logging
import os
import sys

from .errors import InputError

log = logging.getLogger("shellcontact")


class Console:
    """stdout messages (silenced by --quiet) and a progress bar on stderr when it is a terminal."""

    def __init__(self, quiet: bool = False, stream=None) -> None:
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.bar = not quiet and hasattr(self.stream, "isatty") and self.stream.isatty() and not os.environ.get("CI")
        self._drawn = False

    def print(self, *args) -> None:
        if not self.quiet:
            self.clear()
            print(*args, flush=True)

    def progress(self, done: int, total: int, message: str = "") -> None:
        """Draw ``[####....] done/total message`` in place on a terminal; elsewhere (a log, a pipe) one
        line ``[done/total] message`` per step on stderr, unless quiet."""
        if not self.bar:
            if not self.quiet and done:
                print(f"[{done}/{total}] {message}", file=self.stream, flush=True)
            return
        width = 30
        fill = int(width * done / total) if total else width
        text = f"\r[{'#' * fill}{'.' * (width - fill)}] {done}/{total} {message}"[:120]
        self.stream.write(text.ljust(120) if self._drawn else text)
        self.stream.flush()
        self._drawn = True
        if done >= total:
            self.clear()

    def status(self, message: str) -> None:
        """A one-line status in place (terminals only), e.g. solver iterations."""
        if self.bar:
            self.stream.write(("\r" + message)[:120].ljust(121))
            self.stream.flush()
            self._drawn = True

    def clear(self) -> None:
        if self._drawn:
            self.stream.write("\r" + " " * 120 + "\r")
            self.stream.flush()
            self._drawn = False


_saved: list[tuple[list[logging.Handler], bool, int]] = []


def setup_logging(verbose: int, quiet: bool, log_file: str | None) -> None:
    """The command's handlers (stderr, --log), in place of the logger's own until ``restore_logging``."""
    _saved.append((list(log.handlers), log.propagate, log.level))
    log.handlers.clear()
    log.propagate = False
    log.setLevel(logging.DEBUG)
    console = logging.StreamHandler(sys.stderr)
    # warnings change what a result means: they reach stderr even with --quiet
    console.setLevel(logging.WARNING if quiet else (logging.WARNING, logging.INFO, logging.DEBUG)[min(verbose, 2)])
    console.setFormatter(logging.Formatter("%(message)s"))
    log.addHandler(console)
    if log_file:
        try:
            fh = LogFile(os.path.expanduser(log_file))  # "--log=~/x": bash leaves the ~
            fh.stream.write(f"shellcontact log, pid {os.getpid()}\n")  # a full disk is found now, not later
            fh.stream.flush()
        except OSError as exc:
            raise InputError("--log", f"cannot write the log file {log_file!r}: {exc.strerror}") from None
        fh.setLevel(logging.DEBUG)
        fh.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
        log.addHandler(fh)


def restore_logging() -> None:
    """Close the command's handlers and give the logger back its state: a handler left on a stream that its
    caller has closed (a captured stderr) would print a "Logging error" at the next message, and --log's file
    would stay open."""
    if not _saved:
        return
    handlers, propagate, level = _saved.pop()
    for handler in list(log.handlers):
        log.removeHandler(handler)
        handler.close()
    log.handlers[:] = handlers
    log.propagate, log.level = propagate, level


class LogFile(logging.FileHandler):
    """The --log file: a write that fails (a full disk) stops the log with one line on stderr, where
    logging's own handler would print a traceback for every later message."""

    def handleError(self, record: logging.LogRecord) -> None:  # noqa: N802 — logging's name
        exc = sys.exc_info()[1]
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        log.removeHandler(self)
        print(f"warning: --log {self.baseFilename}: {why}; the log stops here (the run goes on)", file=sys.stderr)

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


# -- the run's summary ---------------------------------------------------------------------------------------
def print_summary(con: Console, s: dict) -> None:
    """The run's summary on the console: each number with its unit (and, with --estimate, its estimated error),
    the lines wrapped at ``CONSOLE_WIDTH``."""
    from .units import bracket, with_unit

    system, acc = s.get("unit_system", "SI"), s.get("accuracy", {})

    def q(value: float, kind: str, spec: str = ".6g", path: str = "") -> str:  # a figure with its unit (and
        e = acc.get(path, {}).get("estimate")  # with --estimate its estimated relative error)
        return with_unit(format(value, spec), kind, system) + (f" (±{100 * e:.2g} %)" if e is not None else "")

    def say(head: str, parts: list[str]) -> None:  # console lines of at most CONSOLE_WIDTH characters
        lines, fresh = [head], not head
        for part in parts:
            if not fresh and len(lines[-1]) + 2 + len(part) > CONSOLE_WIDTH:
                lines.append("    ")
                fresh = True
            lines[-1] += ("" if fresh else " " if lines[-1].endswith(":") else "  ") + part
            fresh = False
        con.print("\n".join(lines))

    say("", [f"dofs {s['dofs']}", f"elements {s['elements']}", f"energy {q(s['energy'], 'energy')}",
             f"max|w| {q(s['max_abs_w'], 'length', path='max_abs_w')}"])
    for j, p in enumerate(s.get("probes", [])):
        say(f"probe x={q(p['x'], 'length', 'g')} phi={p['phi']:g} deg:",
            [f"{k}={q(p[k], 'length', path=f'probes.{j}.{k}')}" for k in "uvw"])
    contact = s.get("contact")
    if contact:
        for i, c in enumerate(contact if isinstance(contact, list) else [contact]):
            parts = [
                f"{name} {q(c[k], kind, path=f'contact.{i}.{k}')}"
                for k, name, kind in (("force_magnitude", "force", "force"),
                                      ("total_normal_force", "total normal force", "force"))
                if isinstance(c.get(k), (int, float))
            ]
            zone = c.get("zone")
            if isinstance(zone, dict) and isinstance(zone.get("area"), (int, float)):
                parts.append(f"zone area {q(zone['area'], 'area', path=f'contact.{i}.zone.area')}")
            rim = c.get("rim")
            if isinstance(rim, dict) and rim.get("force"):  # the converging decomposition (rim.py): the area rim
                value = q(rim["mean_line_force"], "force/length", path=f"contact.{i}.rim.mean_line_force")
                parts.append(f"rim line force (mean) {value}")
            loads = rim.get("line_loads") if isinstance(rim, dict) else None
            if isinstance(loads, dict) and loads.get("force"):  # ... and the line loads, apart
                value = q(loads["mean_line_force"], "force/length", path=f"contact.{i}.rim.line_loads.mean_line_force")
                ends = f" (end forces {q(loads['end_force'], 'force')})" if loads.get("end_force") else ""
                parts.append(f"line load {value} over {q(loads['length'], 'length', '.4g')}{ends}")
            if isinstance(rim, dict) and rim.get("kind") == "unresolved":  # carrying rows with no zone round them
                parts.append(f"{q(rim['interior_force'], 'force')} at scattered points no zone resolves (refine)")
            for j, pf in enumerate(rim.get("point_forces", []) if isinstance(rim, dict) else []):
                parts.append(f"point force {q(pf['force'], 'force', path=f'contact.{i}.rim.point_forces.{j}.force')} "
                             f"at x={q(pf['x'], 'length', '.4g')} phi={pf['phi']:.4g} deg")
            say(f"punch {i}:", parts)
    st = s.get("stresses")
    if st:
        name, worst = max(st.items(), key=lambda kv: kv[1]["von_mises_max"])
        util = f"  utilisation {worst['utilisation_max']:.3g}" if "utilisation_max" in worst else ""
        con.print(f"max von Mises {q(worst['von_mises_max'], 'pressure', path=f'stresses.{name}.von_mises_max')} "
                  f"({name} surface, x={q(worst['at']['x'], 'length', '.4g')} phi={worst['at']['phi']:.4g} deg){util}")
    eq = s.get("equilibrium")
    if eq:
        terms = [f"{k} {_vec(eq[k]['force'])}" for k in ("applied", "contact", "reactions") if k in eq]
        say(f"equilibrium, forces{bracket('force', system)}:", [*terms, f"residual {_vec(eq['residual']['force'])} "
                                                               f"(relative {eq['relative_residual']:.1e})"])
    kkt = s.get("kkt")
    if isinstance(kkt, dict) and kkt:
        say("KKT residuals:", [f"{k} {q(v, _KKT_KINDS.get(k, 'strain'), '.3e')}" for k, v in kkt.items()
                               if isinstance(v, float)])


CONSOLE_WIDTH = 100  # the summary's lines wrap here (issue 23: 219 characters)
#: the kind of each unscaled KKT residual (solvers/kkt.py); the others are relative
_KKT_KINDS = {"penetration": "length", "dual_feasibility": "force"}


def _vec(v) -> str:
    return "[" + ", ".join(f"{c:.4g}" for c in v) + "]"

"""shellcontact: a thin elastic cylindrical shell pressed by rigid punches (Bock & Lovíšek 1983).

Commands:
  run          solve one case file; write summary.json, fields.vtu, results.npz, PNG figures, report.html
  demo         the paper's problem by the penalty, active-set and dual methods, side by side
  study        a parameter study over several case-file keys: grid, Latin hypercube, Monte Carlo or a CSV
               table of points, on Dask (an embedded cluster or an existing one); CSV, Parquet, figures
  sweep        a load path: one solve per value of a case-file key, one CSV and plots (resumable)
  convergence  nested mesh refinement: dofs, energy, force/probe value, errors and observed rates
  verify       the paper's results as numerical checks (pass/fail table)
  info         versions, linear-algebra backends, threads

Case-file keys can be overridden with --set KEY=VALUE (dotted path, TOML literal value), e.g.
--set mesh.refine=2 --set punch.0.indentation=2e-3. Exit status: 0 success, 2 bad input,
3 solver failure (residuals printed), 1 other failures. See docs/getting-started.md.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import signal
import sys
import threading
import time
import traceback
from pathlib import Path

from . import __version__
from .console import Console, print_summary, restore_logging, setup_logging
from .errors import InputError, SolverError
from .solvers.methods import METHODS

# Only the standard library and the three modules above at import time (the method registry imports its solvers
# on first use): building the parser and --help must not import NumPy, SciPy, scikit-fem or matplotlib
# (tests/test_startup.py); each command imports what it uses.
EXIT_OK, EXIT_FAIL, EXIT_INPUT, EXIT_SOLVER = 0, 1, 2, 3

log = logging.getLogger("shellcontact")


# -- helpers ------------------------------------------------------------------------------------------------
def _sets(args: argparse.Namespace) -> list[str]:
    sets = list(args.set or [])
    if getattr(args, "method", None):
        sets.append(f'solver.method="{args.method}"')
    return sets


def _load(args: argparse.Namespace):
    from .inputs.user_functions import consent_for
    from .problem.case import load_case

    sets = _sets(args)
    consent_for(args.allow_code, args.allow_module, args.case, "--allow-module")  # names checked, by the flag
    case = load_case(args.case, sets, allow_code=args.allow_code, allow_modules=args.allow_module)
    log.debug("case %s loaded with overrides %s", args.case, sets)
    return case, sets


def _output(args: argparse.Namespace, suffix: str) -> Path:
    """-o DIR, or <case name><suffix> beside the working directory."""
    from .outputs.files import expand_user

    if args.output is None:
        return Path(f"{Path(args.case).stem}{suffix}")
    return expand_user(args.output)  # "--output=~/x": bash leaves the ~; expanded once, here


def _check_profiles(args: argparse.Namespace, shell) -> None:
    """--profile-x / --profile-phi must lie on the shell (the profile is the mesh line nearest them)."""
    ranges = {"--profile-x": (args.profile_x, shell.x_min, shell.x_max),
              "--profile-phi": (args.profile_phi, math.degrees(shell.alpha), math.degrees(shell.beta))}
    for name, (v, lo, hi) in ranges.items():
        if v is not None and not lo <= v <= hi:
            raise InputError(name, f"must lie on the shell, in [{lo:.6g}, {hi:.6g}], got {v:g}")


def _closing(n_warnings: int) -> str:
    return f" ({n_warnings} warning{'s' * (n_warnings != 1)}, see above)" if n_warnings else ""


# -- commands ----------------------------------------------------------------------------------------------
def cmd_run(args: argparse.Namespace, con: Console) -> int:
    from .analysis.pipeline import solve
    from .outputs.run import RUN_FILES, write_run_files
    from .outputs.transaction import replace_dir
    from .studies.accuracy import describe, run_mode

    case, sets = _load(args)
    _check_profiles(args, case.shell)
    out = _output(args, "-out")

    def show(iteration: int, residuals: dict | None = None) -> None:  # once per contact-solver iteration
        worst = max((v for v in (residuals or {}).values() if isinstance(v, float)), default=None)
        con.status(f"solving: iteration {iteration}" + (f", largest residual {worst:.2e}" if worst else ""))

    est = run_mode(case, args.estimate, args.accuracy, args.strict, args.max_levels)  # checked before solving
    with replace_dir(out, overwrite=args.force, owned=RUN_FILES, wait=args.wait) as stage:
        t0 = time.perf_counter()
        con.status("solving ...")
        if est is None:
            result = solve(case, progress=show if con.bar else None, max_memory=args.max_memory)
        else:  # --estimate / --accuracy: the case's mesh and coarser (finer) ones; the finest mesh's result
            est = est(case, max_memory=args.max_memory, announce=con.status)
            result = est.result  # its warnings are logged (stderr) as the solve's are
        con.clear()
        log.info("solved in %.3f s", time.perf_counter() - t0)
        summary = result.summary() if est is None else est.summary()
        n_warnings = len(summary["warnings"])  # each already on stderr (analysis logs them as they arise)
        summary["case_file"] = str(args.case)
        if sets:
            summary["overrides"] = sets
        written = write_run_files(
            result,
            stage,
            summary,
            figures=not args.no_figures,
            report=not args.no_report,
            profile_x=args.profile_x,
            profile_phi=args.profile_phi,
        )
    for name in written:
        log.info("wrote %s", out / name)
    print_summary(con, summary)
    if est is not None:
        con.print("\n".join(describe(est)))
    con.print(f"wrote {out}/: {', '.join(written)}" + _closing(n_warnings))
    return EXIT_FAIL if est is not None and args.strict and not est.met else EXIT_OK


def cmd_demo(args: argparse.Namespace, con: Console) -> int:
    from .demo import run_demo

    return run_demo(_output(args, ""), args.quiet, overwrite=args.force, wait=args.wait)


def cmd_verify(args: argparse.Namespace, con: Console) -> int:
    from .verify import run_verify

    if args.quiet:  # the checks' own solves warn as designed (a penalty's O(eps) residuals): not news
        for handler in log.handlers:
            if type(handler) is logging.StreamHandler:
                handler.setLevel(logging.ERROR)

    return run_verify(quiet=args.quiet)


def _workers(args: argparse.Namespace, default: int | None) -> int | None:
    """--serial, else --workers N (0: in this process), else ``default``."""
    if args.scheduler is not None and (args.serial or args.workers is not None):
        raise InputError("--scheduler", "the points run either on that cluster or here: drop --serial/--workers")
    if args.serial:
        return 0
    if args.workers is not None:
        from .studies.engine import max_workers

        if not 0 <= args.workers <= max_workers():
            raise InputError("--workers", f"must be >= 0 (0: in this process) and at most {max_workers()} (four "
                             f"processes per core), got {args.workers}")
        return args.workers
    return default


def cmd_sweep(args: argparse.Namespace, con: Console) -> int:
    from .studies.sweeps import parse_values, sweep, sweep_table

    values = parse_values(args.values, args.max_memory)
    from .studies.engine import max_workers

    if not 1 <= args.jobs <= max_workers():
        raise InputError("--jobs", f"must be >= 1 and at most {max_workers()} (four processes per core), "
                         f"got {args.jobs}")
    workers = _workers(args, 0 if args.jobs == 1 else args.jobs)
    case, _ = _load(args)
    out = _output(args, "-sweep")
    res = sweep(case, args.param, values, out, overwrite=args.force, wait=args.wait, workers=workers,
                scheduler=args.scheduler, keep_fields=args.keep_fields, progress=con.progress, announce=con.print,
                figures=not args.no_figures, max_memory=args.max_memory)
    if res.reused:
        con.print(f"resumed: {res.reused} of {len(values)} steps were already done")
    con.print(sweep_table(res))
    con.print(f"wrote {out}/: {', '.join(res.files)}")
    return EXIT_OK


def cmd_study(args: argparse.Namespace, con: Console) -> int:
    from .studies.parametric import study, study_table
    from .studies.sampling import parse_spec, read_points, sample

    if args.points and args.param:
        raise InputError("--points", "give either a table of points or -p KEY=SPEC, not both")
    if args.points:
        points, how = read_points(args.points), "points"
    elif args.param:
        specs = [parse_spec(item, args.max_memory) for item in args.param]
        how = args.sample or ("grid" if all(s.dist is None for s in specs) else "lhs")
        points = sample(specs, how, args.samples, args.seed, args.max_memory)
    else:
        raise InputError("-p", "give the keys to vary (-p KEY=SPEC, repeatable) or a table of points (--points)")
    probe = tuple(c.strip() for c in args.probe.split(",") if c.strip())
    case, _ = _load(args)
    out = _output(args, "-study")
    res = study(case, points, out, sampling=how, overwrite=args.force, wait=args.wait,
                workers=_workers(args, None), scheduler=args.scheduler, keep_fields=args.keep_fields,
                probe_components=probe, progress=con.progress, announce=con.print, figures=not args.no_figures,
                max_memory=args.max_memory)
    if res.reused:
        con.print(f"resumed: {res.reused} of {len(points)} points were already done")
    con.print(study_table(res))
    con.print(f"wrote {out}/: {', '.join(res.files)}")
    return EXIT_OK


def cmd_convergence(args: argparse.Namespace, con: Console) -> int:
    from .studies.refinement import convergence, convergence_table

    case, _ = _load(args)
    out = _output(args, "-convergence")
    res = convergence(case, args.levels, out, overwrite=args.force, wait=args.wait, progress=con.progress,
                      figures=not args.no_figures, max_memory=args.max_memory)
    con.print(convergence_table(res))
    con.print(f"wrote {out}/: {', '.join(res.files)}")
    return EXIT_OK


def cmd_info(args: argparse.Namespace, con: Console) -> int:
    from .linalg import BACKENDS, available_backends, default_backend
    from .outputs.report import versions

    v = versions()
    con.print(f"shellcontact {__version__}")
    con.print("  ".join(f"{k} {val}" for k, val in v.items() if k not in ("shellcontact", "platform")))
    con.print(f"platform: {v['platform']}")
    available = available_backends()
    con.print(f"linear-algebra backends: {', '.join(available)} (using {default_backend()}; \"auto\" takes the first)")
    for b in BACKENDS.values():
        con.print(f"  {b.name:<8} {'available' if b.name in available else 'not installed':<13}  {b.doc}")
        if b.details is not None and b.name in available:
            con.print(f"  {'':<8} {'':<13}  {b.details()}")
    env = ", ".join(
        f"{k}={os.environ.get(k, 'unset')}" for k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
    )
    con.print(f"cores: {os.cpu_count()}, {env}")
    return EXIT_OK


# -- parser ----------------------------------------------------------------------------------------------
def _directory(text: str) -> str:
    """An -o/--output value: a directory name (an empty one would silently mean the default, or '.')."""
    if not text.strip():
        raise argparse.ArgumentTypeError("must name a directory, got an empty string")
    return text


def _finite(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return v


def _common(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("output control")
    g.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    g.add_argument("-v", "--verbose", action="count", default=0, help="more messages (-vv: debug)")
    g.add_argument("--log", metavar="FILE", help="also write a detailed log to FILE")


def _output_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--force",
        action="store_true",
        help="replace the files a previous run wrote in a non-empty output directory (kept until the new "
        "result is complete; other files are kept)",
    )
    p.add_argument(
        "--wait", action="store_true", help="wait for another run writing the same directory instead of refusing"
    )


def _case_args(p: argparse.ArgumentParser, out_help: str) -> None:
    p.add_argument("case", help="TOML case file (keys: docs/case-file.md)")
    p.add_argument("-o", "--output", type=_directory, metavar="DIR", help=out_help)
    p.add_argument("--method", choices=tuple(METHODS), help="contact solver; same as --set solver.method=...")
    p.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a case-file key by dotted path, VALUE a TOML literal "
        "(e.g. --set mesh.refine=2 --set punch.0.indentation=2e-3); repeatable",
    )
    _output_args(p)
    p.add_argument("--allow-code", action="store_true", help="let the case's \"module:function\" values import "
                   "Python modules from the case file's own directory (docs/case-file.md, trust model)")
    p.add_argument("--allow-module", action="append", default=[], metavar="MODULE",
                   help="let them import MODULE from the Python path too; repeatable")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.add_argument("--max-memory", metavar="SIZE", help="memory a solve may need, e.g. 8G or 512M (default: the "
                   "memory available); a case estimated to need more is refused before anything is built")


def _engine_args(p: argparse.ArgumentParser, default: str) -> None:
    g = p.add_argument_group("where the points run (docs/studies.md)")
    g.add_argument("--workers", type=int, metavar="N", help=f"an embedded Dask cluster of N worker processes "
                   f"({default}; 0: in this process, as --serial)")
    g.add_argument("--serial", action="store_true", help="solve the points one after another in this process")
    g.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask cluster, e.g. tcp://host:8786 "
                   "(default: the environment variable SHELLCONTACT_SCHEDULER, else an embedded cluster)")
    g.add_argument("--keep-fields", nargs="?", const="npz", choices=("npz", "vtu"), metavar="npz|vtu",
                   help="keep each point's fields: DIR/fields/NNNN/results.npz (vtu: and fields.vtu)")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="shellcontact", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--version", action="version", version=f"shellcontact {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND", help="one of the commands above")

    r = sub.add_parser(
        "run",
        description="Solve one case and write DIR/summary.json, fields.vtu (ParaView), results.npz, "
        "deflection/deformed (and, with contact, pressure) PNG figures and report.html.",
    )
    _case_args(r, "output directory (default: <case name>-out)")
    r.add_argument("--no-report", action="store_true", help="skip report.html")
    a = r.add_argument_group("accuracy (docs/outputs.md#accuracy-of-the-headline-numbers)")
    a.add_argument("--estimate", action="store_true", help="also solve on the two next coarser meshes (about "
                   "1/4 + 1/16 of the cost) and estimate each headline's discretisation error")
    a.add_argument("--accuracy", type=_finite, metavar="TOL", help="refine uniformly until every headline's "
                   "estimated relative error is at most TOL (in [1e-6, 0.5], e.g. 1e-3)")
    a.add_argument("--max-levels", type=int, default=3, metavar="N", help="--accuracy: at most N refinements "
                   "beyond the case's mesh (default 3)")
    a.add_argument("--strict", action="store_true", help="--accuracy: exit 1 when a tolerance is not met")
    r.add_argument("--profile-x", type=_finite, metavar="X", help="pressure profile along the mesh line nearest x = X")
    r.add_argument(
        "--profile-phi", type=_finite, metavar="DEG", help="pressure profile along the mesh line nearest phi = DEG"
    )
    _common(r)
    r.set_defaults(func=cmd_run)

    d = sub.add_parser(
        "demo",
        description="A clamped cylindrical panel pressed by a spherical punch, solved by the "
        "penalty, active-set and dual methods; prints a table and writes DIR.",
    )
    d.add_argument("-o", "--output", type=_directory, metavar="DIR", default="demo-out",
                   help="output directory (default: demo-out)")
    _output_args(d)
    _common(d)
    d.set_defaults(func=cmd_demo)

    s = sub.add_parser(
        "sweep",
        description="A load path: solve the case for each value of a case-file key. Writes "
        "DIR/sweep.csv (parameter, energy, max|w|, probe w, and with contact force, area, peak "
        "pressure), sweep.png, force_indentation.png. Finished steps are recorded in DIR/steps/; "
        "running the same command again resumes without recomputing them.",
    )
    _case_args(s, "output directory (default: <case name>-sweep)")
    s.add_argument("--param", required=True, metavar="KEY", help="case-file key to vary, e.g. punch.0.indentation")
    s.add_argument(
        "--values",
        required=True,
        metavar="SPEC",
        help="start:stop:count (ends included, e.g. 0:5e-3:11) or a comma list (1e-3,2e-3)",
    )
    s.add_argument("--jobs", type=int, default=1, metavar="N",
                   help="solve N steps in parallel processes (default 1: in this process, in order)")
    _engine_args(s, "default: --jobs")
    _common(s)
    s.set_defaults(func=cmd_sweep)

    st = sub.add_parser(
        "study",
        description="A parameter study: solve the case at every point of a full grid (-p KEY=start:stop:count "
        "or KEY=a,b,c), a Latin hypercube or Monte Carlo sample (-p KEY=uniform(lo,hi), normal(mean,sd), "
        "lognormal(median,sigma); --sample lhs|mc, --samples N, --seed S) or a CSV table of points (--points). "
        "Points run as Dask tasks on an embedded cluster (one worker per core) or an existing one "
        "(--scheduler). Writes DIR/study.csv and study.parquet (one row per point: the keys, energy, max|w|, "
        "probe displacements, contact figures), response.png, for random samples histograms.png, "
        "sensitivity.png and sensitivity.csv (Spearman rank correlations), report.html. Finished points are "
        "recorded in DIR/steps/; running the same command again resumes without recomputing them. "
        "See docs/studies.md.",
    )
    _case_args(st, "output directory (default: <case name>-study)")
    st.add_argument("-p", "--param", action="append", metavar="KEY=SPEC",
                    help="a case-file key and its values: start:stop:count, a,b,c, uniform(lo,hi), normal(mean,sd) "
                    "or lognormal(median,sigma); repeatable")
    st.add_argument("--sample", choices=("grid", "lhs", "mc"),
                    help="grid (every combination; the default for value lists), lhs (Latin hypercube; the "
                    "default for distributions) or mc (Monte Carlo)")
    st.add_argument("--samples", type=int, metavar="N", help="number of points of an lhs or mc sample")
    st.add_argument("--seed", type=int, default=0, metavar="S", help="random seed of an lhs or mc sample (default 0)")
    st.add_argument("--points", metavar="CSV", help="a table of points: a header of case-file keys, one row per point")
    st.add_argument("--probe", default="w", metavar="C[,C]",
                    help="the probes' displacement components in each row: u, v, w (default w)")
    _engine_args(st, "default: one per core")
    _common(st)
    st.set_defaults(func=cmd_study)

    c = sub.add_parser(
        "convergence",
        description="Solve with mesh.refine = r0, r0+1, ..., r0+L-1 (r0 the case's value); "
        "print and write DIR/convergence.csv (dofs, h, energy, force or probe value, errors "
        "against the finest level, observed rates), convergence.json and convergence.png.",
    )
    _case_args(c, "output directory (default: <case name>-convergence)")
    c.add_argument("--levels", type=int, default=4, metavar="L", help="number of refinement levels (default 4)")
    _common(c)
    c.set_defaults(func=cmd_convergence)

    v = sub.add_parser(
        "verify",
        description="Run the paper's results (MODEL.md §9) as numerical checks on small cases and print a "
        "pass/fail table with the measured figures; exit status 1 when a check fails.",
    )
    _common(v)
    v.set_defaults(func=cmd_verify)

    i = sub.add_parser("info", description="Versions, linear-algebra backends, cores and thread settings.")
    _common(i)
    i.set_defaults(func=cmd_info)
    return p


def _quiet_exit() -> None:
    """Interrupted: Dask's unfinished tasks are not reported (the process ends now)."""
    if "distributed" in sys.modules:
        from .studies.engine import silence_dask

        silence_dask()


class Terminated(BaseException):
    """SIGTERM or SIGHUP, raised in the main thread so that a run cleans up as after Ctrl-C."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _terminate(signum: int, frame) -> None:
    raise Terminated(signum)


def _install_handlers() -> dict[int, object]:
    """SIGTERM/SIGHUP raise Terminated (SIGINT already raises KeyboardInterrupt); returns the old handlers."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    old = {}
    for sig in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(sig) is not signal.SIG_IGN:  # e.g. nohup: an ignored signal stays ignored
            old[sig] = signal.signal(sig, _terminate)
    return old


def main(argv: list[str] | None = None) -> int:
    """The command line; under ``mpiexec -n N`` rank 0 runs it and the other ranks serve its MUMPS calls
    (``linalg.mpi``: exit status 0 on them, rank 0's status is the run's)."""
    from .launcher import launched_ranks

    if launched_ranks() > 1:
        from .linalg.mpi import run_on_host

        status = run_on_host(lambda: _main(argv))
        return EXIT_OK if status is None else status
    return _main(argv)


def _main(argv: list[str] | None) -> int:
    args = build_parser().parse_args(argv)
    con = Console(quiet=args.quiet)
    handlers = _install_handlers()
    try:
        setup_logging(args.verbose, args.quiet, args.log)
        return args.func(args, con)
    except InputError as exc:
        con.clear()
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except SolverError as exc:
        con.clear()
        print(f"solver failed: {exc}", file=sys.stderr)
        for k, v in exc.residuals.items():
            print(f"  {k:<20} {v:.3e}", file=sys.stderr)
        return EXIT_SOLVER
    except KeyboardInterrupt:
        con.clear()
        _quiet_exit()
        print("interrupted", file=sys.stderr)
        return 128 + signal.SIGINT
    except Terminated as exc:
        con.clear()
        _quiet_exit()
        print(f"terminated by {signal.Signals(exc.signum).name}", file=sys.stderr)
        return 128 + exc.signum
    except OSError as exc:
        con.clear()
        where = f"{exc.filename}: " if exc.filename else ""  # every file we write is named (files, transaction)
        print(f"error: {where}{exc.strerror or exc}", file=sys.stderr)
        return EXIT_INPUT
    except MemoryError:
        con.clear()  # a bounded input (--points, a scheduler's answer) is refused before this: the problem's size
        print("error: not enough memory for this problem: use a coarser mesh (mesh.nx, mesh.nphi, mesh.refine), "
              "fewer points at once (--workers) or --max-memory to be told before anything is built",
              file=sys.stderr)
        return EXIT_INPUT
    except Exception as exc:  # noqa: BLE001 — a bug: one line and where to report it; the traceback under -v/--log
        con.clear()
        print(f"internal error: {type(exc).__name__}: {exc}\nThis is a bug in shellcontact: please report it with "
              "the case file and the output of the same command with -vv --log run.log", file=sys.stderr)
        log.info("".join(traceback.format_exception(exc)).rstrip())
        return EXIT_FAIL
    finally:
        restore_logging()
        for sig, handler in handlers.items():
            signal.signal(sig, handler)


if __name__ == "__main__":
    sys.exit(main())

"""Command line: ``shellcontact run CASE.toml -o DIR``, ``shellcontact info``."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import __version__
from .errors import InputError, SolverError

EXIT_INPUT, EXIT_SOLVER = 2, 3


def _run(args: argparse.Namespace) -> int:
    from .analysis import solve
    from .case import load_case
    from .io import write_json

    out = Path(args.output)
    if out.exists() and any(out.iterdir()) and not args.force:
        raise InputError("--output", f"{str(out)!r} exists and is not empty; use --force to overwrite")
    case = load_case(args.case)
    result = solve(case)
    t0 = time.perf_counter()
    summary = result.summary()
    write_json(out / "summary.json", summary)
    summary["timings"]["output"] = time.perf_counter() - t0
    summary["timings"]["total"] += summary["timings"]["output"]
    write_json(out / "summary.json", summary)
    print(f"dofs {summary['dofs']}  energy {summary['energy']:.6g}  max|w| {summary['max_abs_w']:.6g}")
    for p in summary["probes"]:
        print(f"probe x={p['x']:g} phi={p['phi']:g}: u={p['u']:.6g} v={p['v']:.6g} w={p['w']:.6g}")
    print(f"wrote {out / 'summary.json'}")
    return 0


def _info(args: argparse.Namespace) -> int:
    import os

    import numpy
    import scipy
    import skfem

    from .linalg import available_backends, default_backend

    print(f"shellcontact {__version__}")
    print(f"python {sys.version.split()[0]}, numpy {numpy.__version__}, scipy {scipy.__version__}, "
          f"scikit-fem {skfem.__version__}")
    print(f"linear-algebra backends: {', '.join(available_backends())} (using {default_backend()})")
    print(
        f"cores: {os.cpu_count()}, MKL_NUM_THREADS={os.environ.get('MKL_NUM_THREADS', 'unset')}, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}"
    )
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="shellcontact", description=__doc__)
    p.add_argument("--version", action="version", version=f"shellcontact {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="solve one case file and write DIR/summary.json")
    r.add_argument("case", help="TOML case file (see docs/case-file.md)")
    r.add_argument("-o", "--output", default="out", help="output directory (default: out)")
    r.add_argument("--force", action="store_true", help="overwrite a non-empty output directory")
    r.set_defaults(func=_run)
    i = sub.add_parser("info", help="versions, linear-algebra backends, threads")
    i.set_defaults(func=_info)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except SolverError as exc:
        print(f"solver failed: {exc}", file=sys.stderr)
        return EXIT_SOLVER


if __name__ == "__main__":
    sys.exit(main())

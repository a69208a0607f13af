"""Start-up time: ``shellcontact --help`` and ``import shellcontact`` in fresh processes (issue 11).

    python benchmarks/startup.py                # 10 runs of each command, this checkout and the peer
    python benchmarks/startup.py --quick        # 5 runs
    python benchmarks/startup.py --importtime   # also the slowest top-level imports of each command

Every run is a fresh interpreter (this Python) with PYTHONPATH = the measured tree's src/, so an
installed copy of the package is not what is measured; the wall time is taken with
time.perf_counter around subprocess.run and includes the interpreter's own start (the line
``python -c pass``). Rounds alternate the commands and the two trees, so a change of machine load
hits both alike. Best and median of N; the targets use the median.

The peer is the package before its imports were made lazy (commit PEER_REV), extracted with
``git archive`` into a temporary directory and measured the same way; without git it is left out.
``shellcontact --help`` runs what the installed console script runs (``from shellcontact.cli import
main; sys.exit(main())``). The last line printed is ``{"targets": {"cli_help_seconds": ...,
"import_seconds": ...}, ...}``.
"""

from __future__ import annotations

import argparse
import io
import json
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PEER_REV = "43b6bea"  # the last commit whose shellcontact/__init__.py imported everything eagerly
CLI = "import sys; from shellcontact.cli import main; sys.exit(main())"  # the console script's body

# (name, python arguments, target name, goal in seconds)
COMMANDS: list[tuple[str, list[str], str | None, float | None]] = [
    ("python -c pass", ["-c", "pass"], None, None),
    ("shellcontact --help", ["-c", CLI, "--help"], "cli_help_seconds", 0.3),
    ("shellcontact --version", ["-c", CLI, "--version"], None, None),
    ("import shellcontact", ["-c", "import shellcontact"], "import_seconds", 0.5),
    ("import shellcontact; shellcontact.solve", ["-c", "import shellcontact; shellcontact.solve"], None, None),
]


def environment(src: Path) -> dict:
    env = common.single_thread_env()
    env["PYTHONPATH"] = str(src)
    env.pop("PYTHONSTARTUP", None)
    return env


def run_once(args: list[str], env: dict) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True, timeout=120)
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"python {' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return elapsed


def slowest_imports(args: list[str], env: dict, count: int = 5) -> list[tuple[str, float]]:
    """The top-level imports of one run with the largest cumulative time (python -X importtime)."""
    proc = subprocess.run([sys.executable, "-X", "importtime", *args], env=env, capture_output=True, text=True)
    rows = []
    for line in proc.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        _, cumulative, name = line.split("|", 2)
        if name[1:2] != " ":  # one space after the bar: a top-level import (nested ones are indented)
            rows.append((name.strip(), int(cumulative) / 1e6))
    return sorted(rows, key=lambda r: -r[1])[:count]


def extract_peer(rev: str, into: Path) -> Path | None:
    """``src/`` of commit ``rev`` unpacked under ``into`` (None when git or the commit is unavailable)."""
    try:
        blob = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "src"], capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    with tarfile.open(fileobj=io.BytesIO(blob)) as tar:
        tar.extractall(into, filter="data")
    return into / "src"


def measure(trees: dict[str, Path], runs: int) -> dict[str, dict[str, list[float]]]:
    envs = {label: environment(src) for label, src in trees.items()}
    times: dict[str, dict[str, list[float]]] = {label: {c[0]: [] for c in COMMANDS} for label in trees}
    for env in envs.values():  # one unmeasured round: the first start of a tree compiles its .pyc files
        for _, args, _, _ in COMMANDS:
            run_once(args, env)
    for _ in range(runs):
        for name, args, _, _ in COMMANDS:
            for label, env in envs.items():
                times[label][name].append(run_once(args, env))
    return times


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="5 runs per command instead of 10")
    ap.add_argument("--runs", type=int, help="runs per command (default 10, quick 5)")
    ap.add_argument("--peer", default=PEER_REV, metavar="REV", help=f"git revision of the peer (default {PEER_REV})")
    ap.add_argument("--no-peer", action="store_true", help="measure this checkout only")
    ap.add_argument("--importtime", action="store_true", help="print the slowest top-level imports of each command")
    args = ap.parse_args(argv)
    runs = args.runs or (5 if args.quick else 10)
    info = common.machine()
    print(common.machine_line(info))

    with tempfile.TemporaryDirectory(prefix="startup-peer-") as tmp:
        trees = {"this": ROOT / "src"}
        peer_src = None if args.no_peer else extract_peer(args.peer, Path(tmp))
        if peer_src is not None:
            trees["peer"] = peer_src
        elif not args.no_peer:
            print(f"peer {args.peer}: not available (git archive failed); measuring this checkout only")
        times = measure(trees, runs)
        if args.importtime:
            for label, src in trees.items():
                for name, cmd, _, _ in COMMANDS[1:]:
                    top = ", ".join(f"{m} {t * 1e3:.0f} ms" for m, t in slowest_imports(cmd, environment(src)))
                    print(f"{label:>4} {name}: {top}")

    def stats(label: str, name: str) -> tuple[float | None, float | None]:
        t = times.get(label, {}).get(name)
        return (min(t), statistics.median(t)) if t else (None, None)

    rows, targets, measured = [], {}, {}
    for name, _, target_name, goal in COMMANDS:
        best, median = stats("this", name)
        peer_best, peer_median = stats("peer", name)
        met = None if goal is None else median < goal
        rows.append([name, best, median, peer_best if peer_best is not None else "-",
                     peer_median if peer_median is not None else "-",
                     "-" if goal is None else f"< {goal:g}", "-" if met is None else ("yes" if met else "NO")])
        measured[name] = {"best": best, "median": median, "peer_best": peer_best, "peer_median": peer_median}
        if target_name:
            targets[target_name] = common.target(
                median, goal, f"s, median of {runs} fresh processes: {name}", peer_median,
                best=best, peer_best=peer_best, peer_rev=args.peer if "peer" in trees else None,
            )
    print(f"\nstart-up, wall seconds, {runs} runs each (peer: commit {args.peer}, before the lazy imports)")
    print(common.table(["command", "best s", "median s", "peer best s", "peer median s", "target", "met"], rows))
    out = {"targets": targets, "commands": measured, "runs": runs, "machine": info}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()

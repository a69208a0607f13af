"""The command line run in this process (``shellcontact.cli.main``), as the fuzzer and the bad-input tests use it."""

from __future__ import annotations

import contextlib
import io


def run_cli(args: list[str]) -> tuple[int, str]:
    """``shellcontact ARGS``: (exit status, stderr); an argparse refusal (SystemExit) gives its status."""
    from shellcontact.cli import main

    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main(args)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
    return code, err.getvalue()

"""``python -m nnm sweep``: a job's branches over mistuned or varied models, on Dask.

Exit status (:data:`EXIT_CODES`, the one list: crates/nnm-py/README.md's table is checked
against it):
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator, NoReturn, Sequence

EXIT_OK = 0
EXIT_ERROR = 2
EXIT_SAMPLES = 3
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143

#: Every exit status of ``python -m nnm sweep`` and what it means.
EXIT_CODES = {
    EXIT_OK: "every sample has a row, and every row's status is `ok`",
    EXIT_ERROR: "bad input, an unreachable `--scheduler`, a `--out` holding another sweep's rows, a file that cannot be "
    "read or written: one line on stderr (nothing is written when found before the sweep starts: everything is "
    "checked first)",
    EXIT_SAMPLES: "the sweep ran, but some rows have `status = failed` (and the reason) or some samples no row (an error "
    "on a worker; a rerun computes them): stderr names them",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C): the finished samples are in `sweep.csv`; rerun the same command to go on",
    EXIT_TERMINATED: "stopped by SIGTERM (`kill`, `timeout`, a batch scheduler) as by Ctrl-C: the finished samples are in "
    "`sweep.csv`; rerun the same command to go on",
}

__doc__ += "".join(f"\n- {code}: {meaning}" for code, meaning in EXIT_CODES.items()) + "\n"

#: Rows or samples named in the summary of an unfinished sweep (then "and N more").
NAMED = 10

EPILOG = """\
examples:
  python -m nnm sweep examples/bladed-disk.toml --branch mode-1-14 --out sweep/ \\
      --samples 50 --mistuning 0.01,0.02,0.05 --seed 1
  python -m nnm sweep examples/bladed-disk.toml --out grid/ --grid model.cubic=0.05,0.1,0.2
  python -m nnm sweep examples/forced-bladed-disk.toml --response eo5 --out forced/ \\
      --samples 100 --mistuning 0.01,0.02,0.05   # amplification of the worst blade
  python -m nnm sweep job.toml --out sweep/ --samples 200 --mistuning 0.02 \\
      --scheduler tcp://scheduler:8786      # an existing Dask cluster (crates/nnm-py/README.md, "Sweeps on Dask")

The job's branches give the modes and the energy range (their limits); every branch started
from a mode is swept unless --branch names some (or --response names the job's forced
responses to sweep instead). Rerunning into the same --out skips the
samples already in DIR/sweep.csv.

exit status:
""" + "".join(f"  {code:<4} {meaning}\n" for code, meaning in EXIT_CODES.items())


def _number(text: str) -> int | float:
    """An integer when written as one (a key such as `sectors` takes only integers)."""
    try:
        return int(text)
    except ValueError:
        return float(text)


def _levels(text: str) -> list[int | float]:
    try:
        values = [_number(v.strip()) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers separated by commas, got `{text}`") from None
    if not values:
        raise argparse.ArgumentTypeError("expected at least one number")
    return values


def _grid(text: str) -> tuple[str, list[float]]:
    key, sep, values = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"expected KEY=V1,V2,... (e.g. model.cubic=0.05,0.1), got `{text}`")
    return key.strip(), _levels(values)


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line (as every other error of nnm), pointing to --help."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"error: {message} (see `{self.prog} --help`)\n")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="python -m nnm", description="nnm from Python: parameter and mistuning sweeps on Dask.")
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    s = commands.add_parser(
        "sweep",
        help="follow a job's branches over mistuned or varied models, in parallel",
        description="Follows a job's branches over randomly mistuned bladed disks and/or a grid of job parameters, on Dask, writing DIR/sweep.csv (one row per sample, as each completes), DIR/samples/, DIR/statistics.csv and figures.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    s.add_argument("job", help="the job file (TOML), as for `nnm run`")
    s.add_argument("--out", required=True, metavar="DIR", help="output folder (a rerun into it resumes)")
    s.add_argument("--branch", action="append", metavar="NAME", help="a branch of the job to sweep (repeatable; default: all started from a mode)")
    s.add_argument("--response", action="append", metavar="NAME", help="a [[response]] of the job to sweep instead of branches (one force level; repeatable): per sample its largest blade amplitude and the amplification against the tuned disk")
    s.add_argument("--samples", type=int, default=0, metavar="N", help="mistuned replicates per level")
    s.add_argument("--mistuning", type=_levels, default=[], metavar="SIGMA[,SIGMA...]", help="relative standard deviation(s) of the blade stiffnesses, k_i = k (1 + σ ξ_i)")
    s.add_argument("--seed", type=int, default=0, metavar="S", help="seed of the mistuning draws (default 0)")
    s.add_argument("--grid", type=_grid, action="append", default=[], metavar="KEY=V1,V2,...", help="vary a job key (model.KEY, settings.KEY, branch.NAME.KEY) over values; repeatable, every combination runs")
    s.add_argument("--localization-sectors", type=int, metavar="K", help="sectors counted by the localization, 1 to the model's sectors (default: a tenth of the sectors)")
    where = s.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="W", help="processes of the local Dask cluster, at least 1 (default: one per core)")
    where.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://host:8786")
    s.add_argument("--no-figures", action="store_true", help="write no figures")
    s.add_argument("--quiet", action="store_true", help="print errors only")
    return parser


class Stopped(KeyboardInterrupt):
    """The first Ctrl-C or SIGTERM of a sweep: raised on the main thread wherever it is, so
    that the sweep stops as Ctrl-C stops it (the samples running are cancelled, the Dask
    cluster closed; every finished row is already in ``sweep.csv``)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum

    @property
    def exit_code(self) -> int:
        """128 + the signal's number, as ``nnm run`` exits: 130 for Ctrl-C, 143 for SIGTERM."""
        return 128 + self.signum


#: The signals that stop a sweep, and how the line printed at once names them.
STOPPING = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated (SIGTERM)"}


def _stopped_line(signum: int, out: Path) -> str:
    what = STOPPING[signal.Signals(signum)]
    if (out / "sweep.csv").exists():
        return f"nnm sweep: {what}; the finished samples are in {out}/sweep.csv (rerun to go on)\n"
    return f"nnm sweep: {what}; no sample had finished (rerun to start)\n"


def _quit(signum: int, frame: Any) -> None:
    """A second signal: the process ends at once, by that signal (as shells expect of a
    process that did not finish). Each row of ``sweep.csv`` is one write, which a Python
    handler cannot split: the file holds every row written, whole."""
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


@contextmanager
def _stop_on_signals(out: Path) -> Iterator[None]:
    """While the sweep runs, the first Ctrl-C or SIGTERM prints one line at once (where the
    finished samples are) and raises :class:`Stopped`; a second quits at once. The handlers
    before are restored after (``main`` may be called in-process; signals can only be handled
    on the main thread: elsewhere nothing is installed)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def first(signum: int, frame: Any) -> None:
        for s in STOPPING:
            signal.signal(s, _quit)
        # os.write, not print: the handler may run while the main thread is inside a print to
        # stderr (a buffered write would be a reentrant call).
        os.write(2, _stopped_line(signum, out).encode())
        # The cluster is now closed on purpose: Dask's warnings of this process about it
        # (a worker still computing, then killed) would only blur that line.
        logging.getLogger("distributed").setLevel(logging.ERROR)
        raise Stopped(signum)

    before = {s: signal.getsignal(s) for s in STOPPING}
    try:
        for s in STOPPING:
            signal.signal(s, first)
        yield
    finally:
        for s, handler in before.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        with _stop_on_signals(Path(args.out)):
            return _main(args)
    except Stopped as stopped:  # the user was told when the signal came
        return stopped.exit_code


def _main(args: argparse.Namespace) -> int:
    from .sweeps import sweep

    if args.samples < 0:
        print("error: --samples must be non-negative", file=sys.stderr)
        return EXIT_ERROR
    if args.workers is not None and args.workers < 1:
        print("error: --workers must be at least 1", file=sys.stderr)
        return EXIT_ERROR
    grid = dict(args.grid)
    if len(grid) != len(args.grid):
        print("error: a --grid key is given twice", file=sys.stderr)
        return EXIT_ERROR
    try:
        result = sweep(
            args.job,
            args.out,
            branches=args.branch,
            responses=args.response,
            samples=args.samples,
            mistuning=args.mistuning,
            seed=args.seed,
            grid=grid,
            localization_sectors=args.localization_sectors,
            workers=args.workers,
            scheduler=args.scheduler,
            progress=not args.quiet,
            figures=not args.no_figures,
        )
    except ImportError as e:
        print(f"error: {e} (sweeps need dask[distributed]: pip install 'dask[distributed]')", file=sys.stderr)
        return EXIT_ERROR
    except (ValueError, TypeError, OSError) as e:  # OSError: a scheduler not answering, a file
        print(f"error: {e}", file=sys.stderr)
        return EXIT_ERROR
    if not args.quiet:
        print(f"{result!r}\n  {result.out}/sweep.csv, statistics.csv, samples/{', figures' if not args.no_figures else ''}")
    if result.failed_rows:
        named = _named([f"{r['index']} ({r.get('branch', r.get('response'))}: {r['message'] or r['stop']})" for r in result.failed_rows])
        print(f"nnm sweep: {result.failed} rows of {result.out}/sweep.csv failed, index {named}", file=sys.stderr)
    if result.missing:
        named = _named(result.missing)
        print(f"nnm sweep: {len(result.missing)} samples have no row (rerun to compute them): {named}", file=sys.stderr)
    return EXIT_SAMPLES if result.failed_rows or result.missing else EXIT_OK


def _named(items: list[str]) -> str:
    shown = ", ".join(items[:NAMED])
    return shown + (f" and {len(items) - NAMED} more" if len(items) > NAMED else "")


if __name__ == "__main__":
    sys.exit(main())

"""Property tests of `python -m nnm sweep`'s arguments (issue 29): argument lists generated
from the command's grammar — job files good and bad, grid specs, seeds, levels, counts,
workers, scheduler addresses, --localization-sectors, output folders — each either runs to
completion (exit 0, or 3 with the failed rows named) or is refused with one line and exit 2,
never a traceback, and nothing written when refused.

The command's entry function, nnm.__main__.main, is called in this process (a subprocess
costs a second of imports each). `--workers W` would start a cluster of W processes each time:
instead the command connects, by its own `--scheduler` code, to one in-process cluster shared
by the examples (whose address is also among the generated `--scheduler` values). Addresses
that are well formed but unreachable are left out: each costs the 5 s connection timeout
(test_sweep.py has one)."""

from __future__ import annotations

import contextlib
import csv
import io
import itertools
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
distributed = pytest.importorskip("distributed")

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from nnm import __main__ as cli_module  # noqa: E402
from nnm import sweeps  # noqa: E402

#: A six-sector disk whose branch stops after three points: a sample costs milliseconds.
DISK = """
[model]
family = "bladed-disk"
sectors = 6

[settings]
frequency_shift_max = 0.03
tolerance = 1e-9

[[branch]]
name = "mode-1-2"
mode = "1,2"
max_points = 3
"""

#: Job files by what they hold: only `disk` and `duffing` can run.
JOBS = {
    "disk": DISK,
    "duffing": '[model]\nfamily = "duffing"\n\n[[branch]]\nname = "d"\nmode = 0\nmax_points = 3\n',
    "not-toml": "[model\nfamily = ",
    "empty": "",
    "not-utf8": b"\xff\xfe\x00[model]",
    "unknown-family": '[model]\nfamily = "spaceship"\n',
    "no-branch": '[model]\nfamily = "bladed-disk"\nsectors = 6\n',
}

#: Values per grid key, valid and not; the valid ones keep every sample cheap (few sectors,
#: at most three points).
VALUES = {
    "model.cubic": ["0.05", "0.1", "0", "-0.1", "1e308"],
    "model.sectors": ["3", "4", "6", "8", "2.5", "1"],
    "settings.tolerance": ["1e-9", "1e-6", "1e-30", "0.5"],
    "settings.max_iterations": ["1", "8", "0"],
    "branch.mode-1-2.max_points": ["1", "2", "3", "0", "1.5"],
    "branch.mode-1-2.energy_max": ["0.01", "1", "-1", "1e308"],
    "branch.d.max_points": ["2", "0"],
    "model.blade_stiffness_mistuning": ["0.01"],
    "model.nope": ["1"],
    "branch.nope.max_points": ["2"],
    "settings.integrator": ["1"],
    "cubic": ["0.1"],
    "": ["1"],
}
BAD_NUMBERS = ["nan", "inf", "-inf", "abc", "", "1e-320", "1,,2"]

#: Addresses refused as written (the shared cluster's is added by the fixture).
BAD_SCHEDULERS = ["bogus", "http://localhost:8787", "tcp://:8786", "tcp://localhost:99999", "tcp://::1:8786", "", "tcp://host:port"]


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    """One in-process Dask cluster for every example, its folder, and the job files."""
    base = tmp_path_factory.mktemp("properties")
    jobs = {}
    for name, text in JOBS.items():
        path = base / f"{name}.toml"
        path.write_bytes(text if isinstance(text, bytes) else text.encode())
        jobs[name] = str(path)
    jobs["missing"] = str(base / "missing.toml")
    jobs["a-folder"] = str(base)
    (base / "a-file").write_text("not a folder")
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, protocol="tcp://", dashboard_address=":0"
    ) as cluster:
        yield {"base": base, "jobs": jobs, "address": cluster.scheduler_address, "count": itertools.count()}


@st.composite
def arguments(draw, address: str, jobs: dict[str, str]) -> list[str]:
    """An argument list of `python -m nnm sweep` from its grammar: each part mostly well
    formed (about a third of the lists run), sometimes wrong."""

    def pick(valid: list[str], invalid: list[str]) -> str:
        # One in eight wrong (not st.integers: Hypothesis favours its bounds).
        return draw(st.sampled_from(invalid if draw(st.sampled_from([False] * 7 + [True])) else valid))

    def maybe(option: str, valid: list[str], invalid: list[str]) -> list[str]:
        # `--option=value`: a value such as `-1` or `` is the option's, not a flag.
        return [f"{option}={pick(valid, invalid)}"] if draw(st.booleans()) else []

    job = pick(["disk"] * 3 + ["duffing"], sorted(set(jobs) - {"disk", "duffing"}))
    argv = ["sweep", jobs[job]] if draw(st.sampled_from([True] * 19 + [False])) else ["sweep"]
    argv += [pick(["--out={out}", "--out={out}/a/b"], ["--out={file}", "--out={file}/o", "--out="])]
    if draw(st.sampled_from([False] * 19 + [True])):
        argv.pop()  # --out is required
    for _ in range(draw(st.integers(0, 2))):
        key = pick(["model.cubic", "model.sectors", "settings.tolerance", "settings.max_iterations", "branch.mode-1-2.max_points",
                    "branch.mode-1-2.energy_max", "branch.d.max_points"],
                   ["model.blade_stiffness_mistuning", "model.nope", "branch.nope.max_points", "settings.integrator",
                    "cubic", ""])  # fmt: skip
        values = [pick(VALUES[key], BAD_NUMBERS) for _ in range(draw(st.integers(1, 2)))]
        argv += [pick([f"--grid={key}={','.join(values)}"], [f"--grid={key}", f"--grid=={values[0]}"])]
    argv += maybe("--samples", ["0", "1", "2"], ["-1", "1.5", "x"])
    argv += maybe("--mistuning", ["0", "0.01", "0.05", "0.01,0.05", "0,0.02"], ["-0.1", "0.9", "nan", "inf", "x", "", "0.01,,x"])
    argv += maybe("--seed", ["0", "1", "7", "18446744073709551617"], ["-1", "1.5", "x"])
    argv += maybe("--localization-sectors", ["1", "3", "6"], ["7", "0", "-1", "x"])
    argv += maybe("--branch", ["mode-1-2", "d"], ["nope", ""])
    where = pick(["none", "workers", "scheduler"], ["both"])
    if where in ("workers", "both"):
        argv += [f"--workers={pick(['1', '2'], ['0', '-1', 'x', '1.5'])}"]
    if where in ("scheduler", "both"):
        argv += [f"--scheduler={pick([address], BAD_SCHEDULERS)}"]
    if draw(st.sampled_from([False] * 14 + [True])):
        argv += draw(st.sampled_from([["--bogus"], ["--samples"], ["extra.toml"]]))
    return argv + ["--no-figures", "--quiet"]


def run_main(argv: list[str]) -> tuple[int, str, str]:
    """`python -m nnm ARGV` in this process: its exit status, stdout and stderr."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli_module.main(argv)
        except SystemExit as e:  # argparse
            code = e.code
    return code, out.getvalue(), err.getvalue()


def test_every_argument_list_runs_or_is_refused_in_one_line_writing_nothing(shared, monkeypatch) -> None:
    address, base = shared["address"], shared["base"]
    real_start = sweeps._start_client

    def start(workers, scheduler):
        # --workers W and the default: the shared cluster, reached by the --scheduler code.
        return real_start(None, scheduler if scheduler is not None else address)

    monkeypatch.setattr(sweeps, "_start_client", start)

    @settings(max_examples=30, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
    @given(arguments(address, shared["jobs"]))
    def check(argv: list[str]) -> None:
        out = base / f"out-{next(shared['count'])}"
        file = base / "a-file"
        argv = [a.replace("{out}", str(out)).replace("{file}", str(file)) for a in argv]
        code, stdout, stderr = run_main(argv)
        assert "Traceback" not in stderr
        assert file.read_text() == "not a folder"
        if code == cli_module.EXIT_ERROR:
            assert stderr.startswith("error: ") and stderr.count("\n") == 1, stderr
            assert stdout == ""
            assert not out.exists(), f"{out} written, then refused: {stderr}"
            return
        folder = Path(next(a for a in argv if a.startswith("--out=")).split("=", 1)[1])
        with (folder / "sweep.csv").open(newline="") as f:
            table = list(csv.DictReader(f))
        if code == cli_module.EXIT_OK:
            assert stderr == "" and stdout == ""
            assert table and all(r["status"] == "ok" for r in table)
        else:
            assert code == cli_module.EXIT_SAMPLES, (code, stderr)
            # Every input was checked first: a sample may fail numerically (its row says why),
            # never raise on its worker and go missing.
            assert "have no row" not in stderr, stderr
            lines = stderr.splitlines()
            assert lines and all(line.startswith("nnm sweep: ") for line in lines), stderr
            assert any(r["status"] == "failed" for r in table)

    check()

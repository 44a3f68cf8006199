"""Sweeps on Dask (nnm.sweeps, `python -m nnm sweep`): the mistuned model against an
independent assembly, the localization against the linear mode's shape, a mistuned disk's
split pairs followed to their limits, determinism, resumption, a lost worker, bad input."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

import nnm
from nnm import __main__ as cli_module
from nnm import sweeps

distributed = pytest.importorskip("distributed")

def disk(sectors: int, mode: str) -> str:
    """A bladed-disk job with one branch, `mode-N-D` from mode "N,D"."""
    return SMALL_DISK.replace("sectors = 6", f"sectors = {sectors}").replace("1,2", mode).replace("1-2", mode.replace(",", "-"))


SMALL_DISK = """
[model]
family = "bladed-disk"
sectors = 6

[settings]
frequency_shift_max = 0.03
tolerance = 1e-9

[[branch]]
name = "mode-1-2"
mode = "1,2"
"""


def rows(out: Path) -> list[dict[str, str]]:
    with (out / "sweep.csv").open(newline="") as f:
        return sorted(csv.DictReader(f), key=lambda r: int(r["index"]))


def assert_same_numbers(a: list[dict[str, str]], b: list[dict[str, str]]) -> None:
    """The same rows, bit for bit, but for their timing (the only column allowed to differ)."""
    assert len(a) == len(b)
    for x, y in zip(a, b):
        differ = {k: (x[k], y[k]) for k in x if k != "seconds" and x[k] != y[k]}
        assert not differ, f"sample {x['index']}: {differ}"


def test_mistuned_disk_is_the_tuned_one_with_each_blade_spring_scaled(write_job) -> None:
    """The library's mistuned stiffness against one assembled here from the tuned matrix:
    each blade spring (disk 2i, blade 2i+1) scaled by 1 + σ ξ_i with the documented draw; its
    frequencies (scipy) are the sample's, and the sample follows the mode most like the tuned
    one (the largest mass-weighted MAC, computed here independently)."""
    job = write_job(SMALL_DISK)
    sigma, seed, replicate = 0.05, 11, 2
    tuned = nnm.Model.from_job(job)
    K = tuned.K.toarray()
    M = tuned.M.toarray()
    xi = np.random.default_rng([seed, replicate]).standard_normal(6)
    assert np.array_equal(xi, sweeps.mistuning_draw(seed, replicate, 6))
    for i, d in enumerate(sigma * xi):
        a, b = 2 * i, 2 * i + 1
        K[np.ix_([a, b], [a, b])] += d * np.array([[1.0, -1.0], [-1.0, 1.0]])  # k = 1
    mistuned = nnm.Model.from_job(job, {"model.blade_stiffness_mistuning": list(sigma * xi)})
    assert mistuned.cyclic is None
    assert np.abs(mistuned.K.toarray() - K).max() <= 1e-15

    w2, shapes = scipy.linalg.eigh(K, M)
    frequencies = np.sqrt(np.clip(w2, 0, None))
    # Squared, since the rigid mode's ω² is round-off (1e-16) and ω its square root.
    assert np.allclose(nnm.modes(mistuned).frequencies ** 2, w2, rtol=1e-12, atol=1e-13)

    tuned_modes = nnm.modes(tuned)
    phi = tuned_modes.shapes[:, tuned_modes.index("1,2")]
    mac = (shapes.T @ M @ phi) ** 2
    sample = sweeps.Sample(0, "mode-1-2", (), sigma, replicate)
    result = sweeps.run_sample(str(job), sample, seed)
    row = result["row"]
    assert row["mode"] == int(np.argmax(mac))
    assert row["mac"] == pytest.approx(mac.max(), abs=1e-12)
    assert row["linear_frequency"] == pytest.approx(frequencies[row["mode"]], rel=1e-12)
    assert row["status"] == "ok" and row["frequency_shift"] == pytest.approx(0.03, abs=1e-8)


def test_localization_in_the_linear_regime_is_the_share_of_the_modes_blade_amplitudes(write_job) -> None:
    """Near the linear limit the motion is the mode, x = φ a cos ωt, so the blades' mean
    kinetic energies are ∝ m φ_b,i²: the localization of the first point (from the integrated
    motion) is the share of the top sectors' φ_b,i², from the mode shape alone."""
    job = write_job(disk(30, "1,5"))
    model = nnm.Model.from_job(job)
    modes = nnm.modes(model)
    phi = modes.shapes[:, modes.index("1,5")]
    blade = phi[1::2] ** 2
    top = sweeps.default_top(30)
    assert top == 3
    expected = np.sort(blade)[-top:].sum() / blade.sum()
    result = sweeps.run_sample(str(job), sweeps.Sample(0, "mode-1-5", (), 0.0, 0), seed=0)
    row = result["row"]
    assert row["localization_linear"] == pytest.approx(expected, abs=2e-3)
    # Tuned standing wave: about top × 2 / N of the blades' energy in the top sectors.
    assert 0.15 < row["localization_linear"] < 0.25


@pytest.mark.parametrize("sigma", [1e-4, 0.05])
def test_mistuned_pairs_split_and_each_branch_reaches_its_limit(write_job, sigma: float) -> None:
    """A mistuned 30-sector disk: the (1,5) pair splits (barely at σ = 1e-4: the two modes are
    then as close as the continuation must tell apart), and the branch started from the mode
    most like the tuned cos wave reaches its frequency limit from every draw."""
    job = write_job(disk(30, "1,5"))
    for replicate in range(3):
        row = sweeps.run_sample(str(job), sweeps.Sample(replicate, "mode-1-5", (), sigma, replicate), seed=3)["row"]
        assert row["status"] == "ok", row["message"]
        assert row["stop"] == "frequency-shift-max"
        assert row["frequency_shift"] == pytest.approx(0.03, abs=1e-8)
        if sigma < 1e-3:
            # The tuned cos wave lies in the plane of the split pair, so one of the two holds
            # at least half of it; strong mistuning mixes neighbouring diameters too.
            assert 0.5 - 1e-3 < row["mac"] <= 1.0


def test_sweep_is_deterministic_resumes_and_survives_a_lost_worker(write_job, tmp_path: Path, client) -> None:
    job = write_job(SMALL_DISK)
    grid = {"model.cubic": [0.1, 0.2]}
    first = tmp_path / "first"
    done = sweeps.sweep(job, first, samples=3, mistuning=[0.02], seed=5, grid=grid, client=client, progress=False)
    assert (done.computed, done.skipped, done.failed) == (6, 0, 0)
    reference = rows(first)
    assert len(reference) == 6 and {r["model.cubic"] for r in reference} == {"0.1", "0.2"}
    assert len(list(Path(first, "samples").glob("*.csv"))) == 6  # one branch file a sample
    assert (first / "statistics.csv").exists() and (first / "localization.png").exists()
    # The cubic stiffness hardens the branch: the same frequency shift at lower energy.
    by_cubic = {c: np.median([float(r["energy"]) for r in reference if r["model.cubic"] == c]) for c in ("0.1", "0.2")}
    assert by_cubic["0.2"] < by_cubic["0.1"]

    # A rerun skips everything; more replicates compute only the new ones.
    again = sweeps.sweep(job, first, samples=3, mistuning=[0.02], seed=5, grid=grid, client=client, progress=False)
    assert (again.computed, again.skipped) == (0, 6)
    more = sweeps.sweep(job, first, samples=4, mistuning=[0.02], seed=5, grid=grid, client=client, progress=False)
    assert (more.computed, more.skipped) == (2, 6)

    # An interruption can leave a row cut short: it is dropped and computed again.
    second = tmp_path / "second"
    second.mkdir()
    lines = (first / "sweep.csv").read_text().splitlines(keepends=True)
    kept = [line for line in lines if not line.startswith(("3,", "4,", "5,", "6,", "7,"))]
    (second / "sweep.csv").write_text("".join(kept) + lines[4][:30])
    (second / "sweep.json").write_text((first / "sweep.json").read_text())

    # One worker is killed as the first new result arrives; Dask reruns its sample elsewhere.
    killed = []

    def kill_a_worker(row: dict) -> None:
        if not killed:
            pids = client.run(os.getpid)  # {worker address: its process}
            address = sorted(pids)[0]
            killed.append(address)
            os.kill(pids[address], signal.SIGKILL)  # as a node that goes down: no goodbye

    resumed = sweeps.sweep(
        job, second, samples=4, mistuning=[0.02], seed=5, grid=grid, client=client, progress=False, on_row=kill_a_worker
    )
    assert killed
    assert resumed.computed == 8 - (len(kept) - 1)
    assert_same_numbers(rows(second), rows(first))
    client.wait_for_workers(2, timeout=60)


def test_command_line_sweep_with_two_workers(write_job, tmp_path: Path) -> None:
    job = write_job(SMALL_DISK)
    out = tmp_path / "cli"
    command = [sys.executable, "-m", "nnm", "sweep", str(job), "--out", str(out), "--samples", "2",
               "--mistuning", "0.01", "--seed", "1", "--workers", "2", "--no-figures"]  # fmt: skip
    run = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "[2/2]" in run.stderr and "2 computed" in run.stdout
    table = rows(out)
    assert [r["replicate"] for r in table] == ["0", "1"] and all(r["status"] == "ok" for r in table)
    # The same numbers as computed here, in this process, without Dask.
    here = sweeps.run_sample(str(job.resolve()), sweeps.Sample(1, "mode-1-2", (), 0.01, 1), seed=1)["row"]
    assert float(table[1]["frequency"]) == here["frequency"]
    assert float(table[1]["localization"]) == here["localization"]

    quiet = subprocess.run(command + ["--quiet"], capture_output=True, text=True, timeout=300)
    assert quiet.returncode == 0 and quiet.stdout == "" and quiet.stderr == ""


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--grid", "cubic=0.1"], "expected `model.KEY`"),
        (["--grid", "model.cubic"], "expected KEY=V1,V2"),
        (["--grid", "model.sectors=2.5"], "sectors"),
        (["--grid", "settings.tolerance=1e-30"], "tolerance"),
        (["--mistuning", "-0.1", "--samples", "2"], "non-negative"),
        (["--mistuning", "0.1"], "needs `samples` >= 1"),
        (["--branch", "nope"], "no branch `nope`"),
    ],
)
def test_bad_sweeps_are_one_line_errors_with_status_2(write_job, tmp_path: Path, arguments: list[str], message: str) -> None:
    job = write_job(SMALL_DISK)
    run = subprocess.run(
        [sys.executable, "-m", "nnm", "sweep", str(job), "--out", str(tmp_path / "o"), *arguments],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert run.returncode == 2
    assert message in run.stderr and run.stderr.count("\n") == 1, run.stderr
    assert not (tmp_path / "o").exists()  # everything checked before anything is written


def test_mistuning_is_refused_on_other_models(write_job, tmp_path: Path) -> None:
    job = write_job('[model]\nfamily = "duffing"\n[[branch]]\nname = "d"\nmode = 0\nenergy_max = 1.0\n')
    with pytest.raises(ValueError, match="mistuning applies to a bladed disk"):
        sweeps.sweep(job, tmp_path / "o", samples=2, mistuning=[0.1], progress=False)


def test_a_sample_that_fails_is_a_row_with_its_reason(write_job, tmp_path: Path, client) -> None:
    """One Newton iteration a point cannot converge the first point: that sample is a row with
    `status = failed` and the library's reason, counted in statistics.csv; the others go on,
    and the command line exits 3."""
    job = write_job(SMALL_DISK)
    grid = {"settings.max_iterations": [1, 8]}
    done = sweeps.sweep(job, tmp_path / "o", grid=grid, client=client, progress=False, figures=False)
    assert (done.computed, done.failed) == (2, 1)
    table = {float(r["settings.max_iterations"]): r for r in rows(tmp_path / "o")}
    failed, ok = table[1.0], table[8.0]
    assert failed["status"] == "failed" and failed["points"] == "0"
    assert "did not converge" in failed["message"] and failed["stop"] == "first-point"
    assert ok["status"] == "ok" and int(ok["points"]) > 2 and ok["message"] == ""
    with (tmp_path / "o" / "statistics.csv").open(newline="") as f:
        counts = {float(r["settings.max_iterations"]): r["failed"] for r in csv.DictReader(f)}
    assert counts == {1.0: "1", 8.0: "0"}
    command = [sys.executable, "-m", "nnm", "sweep", str(job), "--out", str(tmp_path / "cli"),
               "--grid", "settings.max_iterations=1,8", "--workers", "1", "--no-figures", "--quiet"]  # fmt: skip
    run = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert run.returncode == 3, run.stderr


# ----------------------------------------------------------------------------------------
# Bad input found before anything runs or is written (issue 29)


def closed_port() -> int:
    """A local port nothing listens on (bound, then released)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def sweep_command(job: Path, out: Path, *arguments: str) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "nnm", "sweep", str(job), "--out", str(out), "--no-figures", *arguments]
    return subprocess.run(command, capture_output=True, text=True, timeout=120)


@pytest.fixture
def threads_client():
    """One in-process worker (processes=False): a test's monkeypatches reach it."""
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as cluster:
        with distributed.Client(cluster) as c:
            yield c


@pytest.mark.parametrize(
    ("scheduler", "message"),
    [
        (None, "no Dask scheduler answered at tcp://127.0.0.1:{port} within 5 s"),  # a closed port
        ("bogus", "scheduler address `bogus`: expected HOST:PORT; e.g. tcp://host:8786"),
        ("http://localhost:8787", "unknown protocol `http://`"),
        ("tcp://localhost:99999", "the port `99999` is not a number from 1 to 65535"),
        ("tcp://:8786", "expected HOST:PORT"),
    ],
)
def test_an_unreachable_or_bogus_scheduler_is_one_line_before_any_file(write_job, tmp_path: Path, scheduler, message) -> None:
    """Refused with one line and status 2, `--out` not even created: the address checked as
    the arguments are, the connection made (with a timeout of SCHEDULER_TIMEOUT) before
    anything is written."""
    job = write_job(SMALL_DISK)
    port = closed_port()
    scheduler = scheduler or f"tcp://127.0.0.1:{port}"
    out = tmp_path / "o"
    run = sweep_command(job, out, "--scheduler", scheduler)
    assert run.returncode == 2, run.stderr
    assert run.stderr.startswith("error: ") and run.stderr.count("\n") == 1, run.stderr
    assert message.format(port=port) in run.stderr
    assert not out.exists()
    assert sweeps.SCHEDULER_TIMEOUT <= 5  # "within 10 s", Python's start included


def test_a_server_that_is_not_a_scheduler_is_one_line_before_any_file(write_job, tmp_path: Path) -> None:
    """`--scheduler` at a port where another server answers (an HTTP server, a proxy): Dask
    read its reply as a message of exabytes and the sweep died with a MemoryError's 40-line
    traceback, status 1. Now one line, status 2, `--out` not created."""
    import socket
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()

    def answer() -> None:
        while True:
            try:
                connection, _ = server.accept()
            except OSError:  # closed at the end of the test
                return
            with connection:
                connection.recv(65536)
                connection.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")

    threading.Thread(target=answer, daemon=True).start()
    job = write_job(SMALL_DISK)
    out = tmp_path / "o"
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    try:
        run = sweep_command(job, out, "--scheduler", address)
    finally:
        server.close()
    assert run.returncode == 2, run.stderr
    assert run.stderr == (
        f"error: what answered at {address} is not a Dask scheduler (MemoryError reading its reply); "
        "is that the scheduler's address and port? Nothing was written\n"
    )
    assert not out.exists()


@pytest.mark.parametrize(
    ("arguments", "error", "message"),
    [
        ({"workers": 0}, ValueError, "workers must be at least 1 (leave it out for one per core), got 0"),
        ({"workers": -1}, ValueError, "workers must be at least 1 (leave it out for one per core), got -1"),
        ({"workers": 1.5}, TypeError, "workers takes an integer, got 1.5"),
        ({"workers": 2, "scheduler": "tcp://h:8786"}, ValueError, "give at most one of `workers`, `scheduler` and `client`"),
        ({"seed": -1}, ValueError, "seed must be at least 0, got -1"),
        ({"seed": 1.5}, TypeError, "seed takes an integer, got 1.5"),
        ({"samples": -2}, ValueError, "samples must be at least 0, got -2"),
        ({"mistuning": ["0.1"], "samples": 2}, TypeError, "a mistuning level is a number, got '0.1'"),
        ({"localization_sectors": 7}, ValueError, "localization_sectors = 7 is more than the model's 6 sectors"),
        ({"workers": 4 * (os.cpu_count() or 1) + 1}, ValueError, "workers must be at most "),
        ({"samples": 500_001, "mistuning": [0.1, 0.2]}, ValueError,
         "the sweep would have 1000002 samples, more than 1000000 (nnm.sweeps.MAX_SAMPLES): fewer `samples`, levels or grid values"),
        ({"grid": {"model.cubic": [0.1 * (1 + i) for i in range(1001)], "settings.tolerance": [1e-9 * (1 + i) for i in range(1000)]}},
         ValueError, "the sweep would have 1001000 samples"),
        ({"localization_sectors": 5, "grid": {"model.sectors": [8, 4]}}, ValueError,
         "grid point model.sectors = 4: localization_sectors = 5 is more than the model's 4 sectors"),
        ({"grid": {"model.sectors": [6, 3]}}, ValueError, "grid point model.sectors = 3: branch `mode-1-2`: unknown mode `1,2`"),
        ({"grid": {"settings.tolerance": [1e-9, 1e-30]}}, ValueError, "grid point settings.tolerance = 1e-30: "),
        ({"grid": {"model.cubic": [0.1, 0.1]}}, ValueError, "grid parameter `model.cubic` has a value twice"),
        ({"samples": 20, "mistuning": [0.01, 0.5], "seed": 0}, ValueError,
         "mistuning σ = 0.5, replicate 5 of seed 0: "),
    ],
)  # fmt: skip
def test_every_grid_point_seed_and_count_is_checked_before_anything_is_written(
    write_job, tmp_path: Path, arguments: dict, error: type, message: str
) -> None:
    """Not only the first grid point: each is read with the job file's rules and each branch's
    mode found on it; every replicate's draw at every level (here replicate 5 of 20 has a
    blade whose stiffness σ = 0.5 would make negative); the counts (`workers = 0` no longer
    "all cores", -1 no longer a hang) and the seed."""
    job = write_job(SMALL_DISK)
    out = tmp_path / "o"
    with pytest.raises(error) as caught:
        sweeps.sweep(job, out, progress=False, figures=False, **arguments)
    assert message in str(caught.value) and "\n" not in str(caught.value)
    assert not out.exists()


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--workers", "0"], "error: --workers must be at least 1"),
        (["--workers", "-1"], "error: --workers must be at least 1"),
        (["--seed", "-1", "--samples", "2", "--mistuning", "0.1"], "seed must be at least 0, got -1"),
        (["--localization-sectors", "7"], "localization_sectors = 7 is more than the model's 6 sectors"),
        # Integers beyond the doubles and any count (issue 29): each one short line, none a hang,
        # a traceback or the system killing the sweep.
        (["--localization-sectors", str(10**400)], "error: localization_sectors = 1e400 is more than the model's 6 sectors"),
        (["--seed", str(-(10**400)), "--samples", "2", "--mistuning", "0.1"], "error: seed must be at least 0, got -1e400"),
        (["--samples", "2", "--mistuning", str(10**400)],
         "error: a mistuning level must be a finite real number, got an integer beyond the float range"),
        (["--samples", str(10**400), "--mistuning", "0.1"],
         "error: the sweep would have 1e400 samples, more than 1000000 (nnm.sweeps.MAX_SAMPLES)"),
        (["--workers", str(10**400)], "error: workers must be at most "),
        (["--grid", "model.sectors=6,3"], "grid point model.sectors = 3: branch `mode-1-2`: unknown mode `1,2`"),
    ],
)
def test_bad_command_lines_write_nothing(write_job, tmp_path: Path, arguments: list[str], message: str) -> None:
    job = write_job(SMALL_DISK)
    out = tmp_path / "o"
    run = sweep_command(job, out, *arguments)
    assert run.returncode == 2 and message in run.stderr and run.stderr.count("\n") == 1, run.stderr
    assert not out.exists()


def test_a_sample_without_a_row_makes_the_sweep_exit_3_naming_it(write_job, tmp_path: Path, threads_client, monkeypatch, capsys) -> None:
    """A sample that raises on its worker has no row (a rerun computes it): the sweep says
    which, `missing` lists it, and the command line exits 3, as for a failed row."""
    job = write_job(SMALL_DISK)
    real = sweeps.run_sample

    def run_sample(job, sample, *args):
        if sample.parameters == (("model.cubic", 0.2),):
            raise RuntimeError("a worker's error")
        return real(job, sample, *args)

    monkeypatch.setattr(sweeps, "run_sample", run_sample)
    monkeypatch.setattr(sweeps, "_start_client", lambda workers, scheduler: (threads_client, None))
    code = cli_module.main(["sweep", str(job), "--out", str(tmp_path / "o"), "--grid", "model.cubic=0.1,0.2", "--no-figures"])
    err = capsys.readouterr().err
    assert code == cli_module.EXIT_SAMPLES == 3, err
    assert "nnm sweep: 1 samples have no row (rerun to compute them): mode-1-2_cubic=0.2" in err
    assert [r["model.cubic"] for r in rows(tmp_path / "o")] == ["0.1"]
    # In Python: the result says so.
    monkeypatch.setattr(sweeps, "run_sample", run_sample)
    result = sweeps.sweep(job, tmp_path / "p", grid={"model.cubic": [0.1, 0.2]}, client=threads_client, progress=False, figures=False)
    assert result.missing == ["mode-1-2_cubic=0.2"] and "1 missing" in repr(result)
    # The failed rows are named too.
    monkeypatch.setattr(sweeps, "run_sample", real)
    code = cli_module.main(["sweep", str(job), "--out", str(tmp_path / "f"), "--grid", "settings.max_iterations=1,8", "--no-figures", "--quiet"])
    err = capsys.readouterr().err
    assert code == 3
    assert err.startswith("nnm sweep: 1 rows of ") and "failed, index 0 (mode-1-2: " in err and err.count("\n") == 1, err


def test_a_rerun_refuses_rows_computed_otherwise(write_job, tmp_path: Path, threads_client) -> None:
    """sweep.json records what defines a row: a rerun after the job file changed, or with
    another --localization-sectors, is refused naming the change (it used to say "0 to run" and
    keep the old rows), and nothing is written; the same sweep resumes."""
    job = write_job(SMALL_DISK)
    out = tmp_path / "o"
    run = dict(client=threads_client, progress=False, figures=False)
    sweeps.sweep(job, out, **run)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}

    job.write_text(SMALL_DISK.replace("frequency_shift_max = 0.03", "frequency_shift_max = 0.05"))
    with pytest.raises(ValueError, match=r"holds rows of a sweep with another job content \(the job file or a file it names changed\): .* use another --out"):
        sweeps.sweep(job, out, **run)
    job.write_text(SMALL_DISK)
    with pytest.raises(ValueError, match=r"another localization_sectors \(the default, now 2\)"):
        sweeps.sweep(job, out, localization_sectors=2, **run)
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    assert sweeps.sweep(job, out, **run).skipped == 1

    # A sweep.json of an nnm that did not record the job's content: refused, not trusted.
    record = json.loads((out / "sweep.json").read_text())
    del record["job_sha256"]
    (out / "sweep.json").write_text(json.dumps(record))
    with pytest.raises(ValueError, match=r"another job content .*\(not recorded by the nnm that wrote it\)"):
        sweeps.sweep(job, out, **run)


def test_the_jobs_content_includes_the_files_it_names(tmp_path: Path) -> None:
    job = tmp_path / "job.toml"
    job.write_text('[model]\nmass = "M.mtx"\nstiffness = \'K.mtx\'\nname = "not-a-file"\n')
    (tmp_path / "M.mtx").write_text("1\n")
    (tmp_path / "K.mtx").write_text("2\n")
    first = sweeps._job_digest(job)
    (tmp_path / "K.mtx").write_text("3\n")
    assert sweeps._job_digest(job) != first
    (tmp_path / "K.mtx").write_text("2\n")
    assert sweeps._job_digest(job) == first


@pytest.mark.parametrize(
    ("corrupt", "message"),
    [
        (lambda line: line.replace(",0.02,", ",abc,", 1), "line 3: sigma `abc` is not a finite number"),
        (lambda line: line.replace(",ok,", ",fine,", 1), "line 3: status `fine` is neither `ok` nor `failed`"),
        (lambda line: line[:40] + "\n", "line 3: 7 fields where the header has 22"),
    ],
)
def test_a_corrupted_row_is_refused_naming_the_file_and_line(write_job, tmp_path: Path, threads_client, corrupt, message) -> None:
    """A row that cannot be read stops the resume with the file and the line (a last row cut
    short by an interruption is still dropped and computed again)."""
    job = write_job(SMALL_DISK)
    out = tmp_path / "o"
    run = dict(samples=3, mistuning=[0.02], seed=5, client=threads_client, progress=False, figures=False)
    sweeps.sweep(job, out, **run)
    path = out / "sweep.csv"
    lines = path.read_text().splitlines(keepends=True)
    lines[2] = corrupt(lines[2])
    path.write_text("".join(lines))
    with pytest.raises(ValueError) as caught:
        sweeps.sweep(job, out, **run)
    assert f"{path}, {message}" in str(caught.value) and "\n" not in str(caught.value)
    assert path.read_text() == "".join(lines)  # left as it was


def test_an_infinite_grid_value_is_a_row_a_rerun_reads_and_nan_is_refused(write_job, tmp_path: Path, threads_client) -> None:
    """A job's limit may be infinite (`energy_max = inf`: none), so a grid may hold it: its
    rows were written, then refused as "not a finite number" after the sweep (exit 2 with the
    files written; found by test_sweep_properties.py). NaN, which no row can match on a
    rerun, is refused before anything is written."""
    job = write_job(SMALL_DISK)
    out = tmp_path / "o"
    run = dict(grid={"branch.mode-1-2.energy_max": [10.0, float("inf")]}, client=threads_client, progress=False, figures=False)
    done = sweeps.sweep(job, out, **run)
    assert (done.computed, done.failed, done.missing) == (2, 0, [])
    assert [r["branch.mode-1-2.energy_max"] for r in rows(out)] == ["10.0", "inf"]
    again = sweeps.sweep(job, out, **run)
    assert (again.computed, again.skipped) == (0, 2)
    with pytest.raises(ValueError, match=r"^grid parameter `branch.mode-1-2.energy_max` takes numbers, got nan$"):
        sweeps.sweep(job, tmp_path / "n", **{**run, "grid": {"branch.mode-1-2.energy_max": [10.0, float("nan")]}})
    assert not (tmp_path / "n").exists()


def test_the_readme_lists_the_modules_exit_codes() -> None:
    """The exit statuses are declared once, in nnm.__main__.EXIT_CODES (its docstring and
    --help print them): the README's table says the same."""
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    table = readme.split("| `python -m nnm sweep` exit status | meaning |\n|---|---|\n", 1)[1].split("\n\n", 1)[0]
    listed = {}
    for line in table.splitlines():
        code, meaning = line.strip("|").split("|", 1)
        listed[int(code.strip().strip("`"))] = meaning.strip()
    assert listed == cli_module.EXIT_CODES
    assert all(f"- {code}: {meaning}" in cli_module.__doc__ for code, meaning in cli_module.EXIT_CODES.items())


# ----------------------------------------------------------------------------------------
# Signals (issue 29): SIGTERM stops a sweep as the first Ctrl-C does; a second signal quits


def wait_for(condition, what: str, process: subprocess.Popen, limit: float = 120.0) -> None:
    """Polls `condition` until it holds (the limit only fails a test that would hang)."""
    import time

    deadline = time.monotonic() + limit
    while not condition():
        if process.poll() is not None:
            pytest.fail(f"the process ended ({process.returncode}) before {what}")
        if time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"no {what} within {limit} s")
        time.sleep(0.05)


#: A branch of two points, and the same branch stepped by 1e-5 of its amplitude over 100,000
#: points (minutes): the sweep is still computing the second when the first's row is written.
SLOW_DISK = SMALL_DISK.replace('mode = "1,2"', 'mode = "1,2"\nmax_step = 1e-5\nmin_step = 1e-7\nenergy_max = 1e9')


def test_sigterm_stops_a_sweep_keeping_its_rows_as_ctrl_c_does(write_job, tmp_path: Path) -> None:
    """SIGTERM (`kill`, `timeout`, a batch scheduler) mid-sweep: the finished row stays in
    sweep.csv, one line says where, the exit code is 143 (as `nnm run`'s), and a rerun of the
    finished sample finds it done."""
    job = write_job(SLOW_DISK)
    out = tmp_path / "o"
    command = [sys.executable, "-m", "nnm", "sweep", str(job), "--out", str(out), "--workers", "2",
               "--grid", "branch.mode-1-2.max_points=2,100000", "--no-figures", "--quiet"]  # fmt: skip
    with (tmp_path / "stderr").open("w+") as stderr:
        process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=stderr, text=True)
        try:
            wait_for(lambda: (out / "sweep.csv").exists() and len(rows(out)) >= 1, "first row", process)
            process.send_signal(signal.SIGTERM)
            code = process.wait(timeout=120)
            assert code == 143 == cli_module.EXIT_TERMINATED
        finally:
            process.kill()
        stderr.seek(0)
        lines = stderr.read().splitlines()
    told = f"nnm sweep: terminated (SIGTERM); the finished samples are in {out}/sweep.csv (rerun to go on)"
    assert lines.count(told) == 1, lines
    assert not any("Traceback" in line or "distributed.nanny" in line for line in lines), lines
    table = rows(out)
    assert [(r["branch.mode-1-2.max_points"], r["status"], r["points"]) for r in table] == [("2", "ok", "2")]
    rerun = sweep_command(job, out, "--grid", "branch.mode-1-2.max_points=2", "--workers", "1")
    assert rerun.returncode == 0, rerun.stderr
    assert "1 samples, 1 already in" in rerun.stderr and "0 to run" in rerun.stderr


STOPPING_SCRIPT = """
import sys, time
from pathlib import Path
from nnm.__main__ import Stopped, _stop_on_signals

with _stop_on_signals(Path(sys.argv[1])):
    try:
        print("running", flush=True)
        while True:
            time.sleep(1)
    except Stopped as stopped:
        print(f"stopping {stopped.exit_code}", flush=True)
        while True:  # a cleanup that never ends: only a second signal ends the process
            time.sleep(1)
"""


@pytest.mark.parametrize(
    ("first", "line"),
    [
        (signal.SIGTERM, "nnm sweep: terminated (SIGTERM); the finished samples are in {out}/sweep.csv (rerun to go on)"),
        (signal.SIGINT, "nnm sweep: interrupted; the finished samples are in {out}/sweep.csv (rerun to go on)"),
    ],
)
@pytest.mark.parametrize("second", [signal.SIGTERM, signal.SIGINT])
def test_the_first_signal_stops_the_sweep_and_a_second_quits_at_once(tmp_path: Path, first, line, second) -> None:
    """The first Ctrl-C or SIGTERM says at once where the finished samples are and stops the
    sweep (its exit code 128 + the signal's number); a second, during the cleanup, ends the
    process at once, by that signal."""
    out = tmp_path / "o"
    out.mkdir()
    (out / "sweep.csv").write_text("index\n")
    process = subprocess.Popen(
        [sys.executable, "-c", STOPPING_SCRIPT, str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert process.stdout.readline() == "running\n"
        process.send_signal(first)
        assert process.stdout.readline() == f"stopping {128 + first}\n"
        process.send_signal(second)
        assert process.wait(timeout=60) == -second
        assert process.stderr.read() == line.format(out=out) + "\n"
    finally:
        process.kill()


def test_the_line_says_when_no_sample_had_finished(tmp_path: Path) -> None:
    assert cli_module._stopped_line(signal.SIGTERM, tmp_path / "o") == "nnm sweep: terminated (SIGTERM); no sample had finished (rerun to start)\n"

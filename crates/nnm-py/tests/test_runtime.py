"""How a run behaves in a Python program: the GIL is released, Ctrl-C and callbacks stop it
between points, and a progress bar shows where tqdm is installed."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

import nnm

# The (1,5) backbone of the bladed disk with its events located, to a far energy: about a
# second on one core, long enough to be interrupted and to watch another thread run.
LONG = {"mode": (1, 5), "energy_max": 1e9, "progress": False}


def test_ctrl_c_stops_a_run_between_points_and_the_model_stays_usable() -> None:
    model = nnm.bladed_disk()
    timer = threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        # Without the check between points the run would reach energy_max and return.
        with pytest.raises(KeyboardInterrupt) as interrupted:
            nnm.backbone(model, **LONG)
    finally:
        timer.cancel()
    # The points computed before the interrupt come with it: the same as a run stopped there.
    partial = interrupted.value.branch
    assert len(partial) >= 1 and partial.stop_kind == "interrupted"
    again = nnm.backbone(model, (1, 5), max_points=len(partial), progress=False)
    assert list(again.energy) == list(partial.energy)


def test_the_gil_is_released_while_the_library_computes() -> None:
    """A Python loop on the main thread keeps running while another thread computes a
    branch: its longest pause is far below the computation's duration (with the GIL held
    throughout it would be all of it)."""
    model = nnm.bladed_disk()
    done = threading.Event()
    worker = threading.Thread(target=lambda: (nnm.backbone(model, **LONG), done.set()))
    began = time.perf_counter()
    worker.start()
    last, longest = began, 0.0
    while not done.is_set():
        now = time.perf_counter()
        longest, last = max(longest, now - last), now
    worker.join()
    duration = time.perf_counter() - began
    assert duration > 0.3
    assert longest < 0.25 * duration, (longest, duration)


def test_a_callback_sees_every_point_and_can_stop_the_branch() -> None:
    seen = []

    def callback(index: int, energy: float, frequency: float, stable: bool):
        seen.append((index, energy, frequency, stable))
        return len(seen) < 4  # False after the fourth point: stop

    branch = nnm.backbone(nnm.duffing(), 0, energy_max=10.0, callback=callback, progress=False)
    assert branch.stop_kind == "callback" and len(branch) == 4
    assert [s[1] for s in seen] == list(branch.energy)
    assert [s[0] for s in seen] == list(branch.index)


def test_an_exception_in_the_callback_propagates() -> None:
    def callback(*point):
        raise LookupError("from the callback")

    with pytest.raises(LookupError, match="from the callback") as raised:
        nnm.backbone(nnm.duffing(), 0, energy_max=10.0, callback=callback, progress=False)
    # The first point was computed (the callback raised on it) and comes with the exception.
    assert len(raised.value.branch) == 1 and raised.value.branch.energy[0] > 0


def test_a_progress_bar_counts_the_points(capsys) -> None:
    pytest.importorskip("tqdm")
    branch = nnm.backbone(nnm.duffing(), 0, frequency_shift_max=0.2, progress=True)
    err = capsys.readouterr().err
    assert f"{len(branch)} points" in err and "mode 0" in err
    nnm.backbone(nnm.duffing(), 0, frequency_shift_max=0.2, progress=False)
    assert capsys.readouterr().err == ""

"""step(n) releases the GIL: Python threads run while a simulation steps."""

import threading
import time

import pytest

import simkit


def test_thread_runs_during_step():
    sim = simkit.Md.fcc(8, dt=0.005)  # 2048 atoms: one step(400) call lasts well over 1 ms
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    time.sleep(0.02)
    before = len(ticks)
    start = time.perf_counter()
    sim.step(400)
    end = time.perf_counter()
    stop.set()
    t.join()
    during = [x for x in ticks if start <= x <= end]
    # The counting thread ticks about once per millisecond while step runs; with the GIL
    # held through the step it would not tick at all (at most once, at the edges).
    assert len(during) >= 5, (before, len(during), end - start)


def test_second_thread_is_refused_while_stepping():
    """Another thread touching a simulation while it steps gets a RuntimeError at once (it
    neither blocks holding the GIL, which would deadlock, nor sees a half-updated state)."""
    sim = simkit.Md.fcc(6, dt=0.005)
    started = threading.Event()
    t = threading.Thread(target=lambda: (started.set(), sim.step(2000)))
    t.start()
    started.wait()
    time.sleep(0.05)
    busy = t.is_alive()
    with pytest.raises(RuntimeError, match="(?i)borrow"):
        sim.positions  # noqa: B018 (the access is the test)
    t.join()
    assert busy
    assert sim.steps_done == 2000


@pytest.mark.parametrize("make", [
    lambda: simkit.Rd.gray_scott_square(128),
    lambda: simkit.LatticeGas.random(256, 128, 0.3),
    lambda: simkit.PpCoulomb.cold_sphere(1000, dt=0.01),
    lambda: simkit.Dem.vibrating_bed(128, 16),
])
def test_every_class_steps_in_a_thread(make):
    sim = make()
    t = threading.Thread(target=sim.step, args=(20,))
    t.start()
    t.join()
    assert sim.steps_done == 20

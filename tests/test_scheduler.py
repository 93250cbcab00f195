"""scheduler.py: Snakemake's scheduler keeps one pending wake-up, and is never left without one it asked for."""
from __future__ import annotations

import threading
import time
from types import SimpleNamespace

from snakemake.scheduling.job_scheduler import JobScheduler

from clothscope.core import scheduler


def releases(loop: SimpleNamespace) -> int:
    """How many times the loop was released so far (taking them)."""
    count = 0
    while loop._open_jobs.acquire(blocking=False):
        count += 1
    return count


def test_wakeups_asked_while_one_is_pending_start_no_other_timer():
    loop = SimpleNamespace(_open_jobs=threading.Semaphore(0))
    threads = threading.active_count()
    for _ in range(50):
        scheduler.one_pending_wakeup(loop, 0.2)
    assert threading.active_count() <= threads + 1
    time.sleep(0.5)
    assert releases(loop) == 1


def test_a_pass_after_the_wakeup_can_ask_for_the_next():
    loop = SimpleNamespace(_open_jobs=threading.Semaphore(0))
    for _ in range(3):
        scheduler.one_pending_wakeup(loop, 0.05)
        assert loop._open_jobs.acquire(timeout=2.0)  # the loop's next pass, as Snakemake's waits for it
    assert releases(loop) == 0


def test_the_pinned_snakemake_scheduler_is_changed():
    assert scheduler.keep_one_scheduler_wakeup()
    assert getattr(JobScheduler, scheduler.WAKEUP_METHOD) is scheduler.one_pending_wakeup

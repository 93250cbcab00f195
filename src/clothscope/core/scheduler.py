"""Snakemake's job scheduler: at most one pending wake-up of its loop.

Snakemake 9 (the pinned 9.27.1 included) ends every pass of its scheduling loop by starting a timer
that wakes the loop again after the job-rate limit's timespan (``--max-jobs-per-timespan``, on by
default at 100 jobs a second), also when such a timer is already pending. A pass that a finished job
started thus adds a timer chain that never ends: after N job events the loop runs about N times a
second, and on a small machine it takes the CPU from the jobs. :func:`keep_one_scheduler_wakeup`
makes the scheduler keep one pending wake-up at most, which is all the rate limit needs.
"""
from __future__ import annotations

import threading
from typing import Any

#: the JobScheduler method that starts the wake-up timer (its spelling in Snakemake)
WAKEUP_METHOD = "_schedule_reevalutation"


def _wake(scheduler: Any) -> None:
    """Mark the wake-up as spent, then let the scheduler's loop run one pass."""
    scheduler._clothscope_wakeup_pending = False
    scheduler._open_jobs.release()


def one_pending_wakeup(scheduler: Any, delay: float) -> None:
    """Wake ``scheduler``'s loop after ``delay`` seconds unless a wake-up is already pending.

    The flag is cleared before the loop is released, so every pass that follows a wake-up can
    start the next one: the loop is never left without a pending wake-up it asked for.
    """
    if getattr(scheduler, "_clothscope_wakeup_pending", False):
        return
    scheduler._clothscope_wakeup_pending = True
    timer = threading.Timer(delay, _wake, args=(scheduler,))
    timer.daemon = True  # never holds up Snakemake's exit
    timer.start()


def keep_one_scheduler_wakeup() -> bool:
    """Make Snakemake's JobScheduler keep one pending wake-up at most.

    Returns
    -------
    bool
        True when the scheduler was changed; False (nothing changed) where this Snakemake has no
        such method.
    """
    try:
        from snakemake.scheduling.job_scheduler import JobScheduler
    except ImportError:
        return False
    if not callable(getattr(JobScheduler, WAKEUP_METHOD, None)):
        return False
    setattr(JobScheduler, WAKEUP_METHOD, one_pending_wakeup)
    return True

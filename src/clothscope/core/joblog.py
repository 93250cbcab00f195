"""Logging for Snakemake script jobs: everything a job prints goes to its ``log:`` file."""
from __future__ import annotations

import contextlib
import logging
import os
import sys
from collections.abc import Iterator
from pathlib import Path


@contextlib.contextmanager
def job_log(log_path: str | os.PathLike[str], name: str) -> Iterator[logging.Logger]:
    """Send Python logging, stdout and stderr of this job to ``log_path``."""
    Path(log_path).parent.mkdir(parents=True, exist_ok=True)
    with open(log_path, "w", encoding="utf-8") as stream, contextlib.redirect_stdout(stream), contextlib.redirect_stderr(stream):
        handler = logging.StreamHandler(stream)
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        logger = logging.getLogger(name)
        logger.handlers[:] = [handler]
        logger.setLevel(logging.INFO)
        logger.propagate = False
        try:
            yield logger
        except Exception:
            logger.exception("job failed")
            print(f"clothscope: {name} failed, see {log_path}", file=sys.__stderr__)
            raise

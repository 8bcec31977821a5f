"""The E2 drivers' resumable files: one JSON line a finished trial, read back to skip what is done.

A trial's line is written whole and synced before the next trial starts, so a sweep stopped at any moment keeps
every trial it finished; a line cut short by that stop is skipped when read and closed before the next one is
appended.
"""
from __future__ import annotations

import json
import os
from pathlib import Path


def read_rows(path: Path) -> list[dict]:
    """The finished trials in the jsonl (none when it does not exist; a line cut short by a stopped run is
    skipped)."""
    if not path.exists():
        return []
    rows = []
    for line in path.read_text().splitlines():
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return rows


def close_cut_line(path: Path) -> None:
    """End a line cut short by a stopped run, so that the next trial starts a line of its own."""
    if path.exists() and path.stat().st_size and not path.read_bytes().endswith(b"\n"):
        with path.open("a") as handle:
            handle.write("\n")


def append_row(path: Path, row: dict) -> None:
    """One line a trial, flushed and synced: a stopped run keeps what it finished."""
    with path.open("a") as handle:
        handle.write(json.dumps(row) + "\n")
        handle.flush()
        os.fsync(handle.fileno())

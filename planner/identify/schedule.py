"""Power schedules as CSV files for a programmable electronic load.

The test signals of :mod:`planner.identify.protocols` (two-step tests, APRBS) are written
for the bench and read back for the virtual bench (``endurance design``, ``bench``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from planner.io import files
from planner.identify.protocols import SCHEDULE_COLUMNS
from planner.errors import InputError

__all__ = ["read_schedule", "write_schedule"]


def write_schedule(schedule: pd.DataFrame, path: str | os.PathLike,
                   comment: str | None = None, option: str = "output") -> Path:
    """Write a power schedule as a CSV for a programmable load (constant-power mode).

    Format: ``#`` comment lines (what it is, units, ``comment``), then the header
    ``time_s,power_w`` and one row per step: from ``time_s`` [s] on, draw
    ``power_w`` [W] until the next row; the last row (power 0) switches the load
    off at the end. Read it back with :func:`read_schedule`. ``option`` names the output
    in messages (the command line's option).
    """
    path = Path(path)
    starts = schedule["start_s"].to_numpy(float)
    end = float(starts[-1] + schedule["duration_s"].to_numpy(float)[-1]) if len(starts) else 0.0
    lines = ["# power schedule for a programmable electronic load in constant-power mode",
             ("# time_s [s]: time the step starts; power_w [W]: constant power from then until "
             "the next row; last row: load off")]
    if comment:
        lines += [f"# {line}" for line in str(comment).splitlines()]
    lines.append("time_s,power_w")
    lines += [f"{t:g},{p:g}" for t, p in zip(starts, schedule["power_w"].to_numpy(float))]
    lines.append(f"{end:g},0")
    files.write_text(path, "\n".join(lines) + "\n", option)
    return path


def read_schedule(path: str | os.PathLike) -> pd.DataFrame:
    """Read a CSV written by :func:`write_schedule` back into a schedule table."""
    path = Path(path)
    try:
        df = pd.read_csv(files.input_path(path, "table", "power schedule"), comment="#")
    except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise InputError(f"{path}: not a readable power schedule ({exc})") from None
    if list(df.columns) != ["time_s", "power_w"]:
        raise InputError(f"{path}: expected columns time_s,power_w, got "
                         f"{','.join(map(str, df.columns))}")
    t = df["time_s"].to_numpy(float)
    if len(t) < 2 or np.any(np.diff(t) <= 0):
        raise InputError(f"{path}: time_s must increase row by row (at least two rows)")
    return pd.DataFrame({"start_s": t[:-1], "duration_s": np.diff(t),
                         "power_w": df["power_w"].to_numpy(float)[:-1]},
                        columns=list(SCHEDULE_COLUMNS))

"""Measured data in, flight record out: one loader for every command that reads data.

A path is a flight-record CSV (a table with ``time_s``, docs/record.md) or any log
the readers take (:func:`planner.io.logs.read_log`); several paths are stacked
into one record with one ``experiment`` per file (or per the file's own
``experiment`` column).
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import pandas as pd

from planner.io import record as rec
from planner.errors import InputError


def _is_record_csv(path: Path) -> bool:
    """A flight-record CSV: a ``.csv`` or ``.csv.gz`` file whose header names ``time_s``
    (a damaged compressed one is named by the record reader)."""
    name = path.name.lower()
    if not (name.endswith(".csv") or name.endswith(".csv.gz")):
        return False
    try:
        return "time_s" in rec.read_header(path)
    except InputError:
        if name.endswith(".gz"):
            raise
        return False  # unreadable: let the reader name the problem


def _read_one(p: Path, column_map, require_battery: bool, battery_instance: int | None = None):
    if not p.exists():
        raise InputError(f"{p}: file not found")
    if column_map is None and _is_record_csv(p):
        df = rec.read_record(p)
        return df, {"source": str(p), "format": "flight-record CSV", "warnings": []}
    from planner.io.logs import read_log
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        opts = {"require_battery": require_battery}
        if column_map is not None:
            opts["map"] = column_map
        if battery_instance is not None:
            opts["battery_instance"] = battery_instance
        return read_log(p, **opts)


def load_flight_data(paths, *, column_map=None, require_battery: bool = True,
                     failed: list[str] | None = None, battery_instance: int | None = None
                     ) -> tuple[pd.DataFrame, list[dict]]:
    """Read one or more data files into one flight record.

    Parameters
    ----------
    paths : path or list of paths
        Flight-record CSV files or logs (.bin, .px4log, .tlog, .ulg, mapped CSV, a folder
        or zip of PX4 topic CSV files).
    column_map : path or dict, optional
        Column map for CSV files that are not flight records
        (:mod:`planner.io.logs.csvmap`).
    require_battery : bool
        Logs without battery voltage and current are an error.
    failed : list, optional
        A batch: a file that cannot be read appends its one-line error to this list and
        the others are read (an error only when none can be). Without it the first bad
        file raises.
    battery_instance : int, optional
        The ``battery_status`` instance of PX4 topic exports (folders or zips of
        ``ulog2csv`` files; :mod:`planner.io.logs.ulog2csv`).

    Returns
    -------
    (DataFrame, list of dict)
        The record, with ``power_w`` and ``consumed_mah`` filled in, and one
        metadata dict per file.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    frames, metas, read = [], [], []
    first_error: InputError | None = None
    for p in map(Path, paths):
        try:
            df, meta = _read_one(p, column_map, require_battery, battery_instance)
        except InputError as exc:
            if failed is None:
                raise
            failed.append(str(exc))
            first_error = first_error or exc
            continue
        read.append(p)
        stem = p.name.split(".")[0]
        if "experiment" not in df.columns:
            df = df.assign(experiment=stem)
        df = df.assign(experiment=df["experiment"].astype(str))
        frames.append(rec.complete_record(df))
        metas.append(meta)
    if not frames:
        if first_error is not None:
            raise first_error if len(paths) == 1 else InputError(
                f"none of the {len(paths)} files could be read (the first: {first_error})")
        raise InputError("no data files given")
    paths = read
    seen: set[str] = set()
    for i, (frame, path) in enumerate(zip(frames, paths)):
        ids = set(frame["experiment"].unique())
        if ids & seen:  # the same id in two files: prefix with the file name
            frames[i] = frame.assign(
                experiment=Path(path).name.split(".")[0] + ":" + frame["experiment"])
            ids = set(frames[i]["experiment"].unique())
        seen |= ids
    data = pd.concat(frames, ignore_index=True)
    # an experiment must span some time to be analysed: drop instants with a warning
    span = data.groupby("experiment", sort=False)["time_s"].agg(["size", "min", "max"])
    instant = span.index[(span["size"] < 2) | ~(span["max"] > span["min"])]
    if len(instant) == len(span):
        raise InputError(f"{', '.join(map(str, paths))}: no experiment spans more than one "
                         "instant (every one has fewer than 2 samples or all its samples at "
                         "the same time_s); expected samples over time")
    if len(instant):
        warnings.warn(f"skipped experiment(s) {', '.join(map(str, instant[:5]))}"
                      f"{' …' if len(instant) > 5 else ''}: fewer than 2 samples or no time "
                      "between them", stacklevel=2)
        data = data[~data["experiment"].isin(instant)].reset_index(drop=True)
    return data, metas

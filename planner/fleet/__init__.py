"""Fleet: many logs on Dask → a flight table, pack health and the planner's accuracy.

:func:`run_fleet` is ``endurance fleet``:

1. the logs (files, or folders searched for ``.bin``, ``.px4log``, ``.tlog``, ``.ulg``)
   are summarised one per task on a Dask distributed cluster — a ``LocalCluster`` of
   process workers (one thread each) by default, or the scheduler at ``scheduler`` —
   by :func:`planner.fleet.summary.summarise_log`; a log whose content hash is already
   in ``DIR/flights.parquet`` with ``status = ok`` is not read again; a log that fails
   is a ``failed`` row with its reason, a log that is not of the aircraft or pack it is
   flown with a ``mismatch`` row (:func:`planner.fleet.summary.check_match`), a log
   without airborne samples a ``not airborne`` row — neither counts in the accuracy,
   the pack health or the calibration;
2. the table is written to ``DIR/flights.parquet`` (one row per flight,
   :data:`planner.fleet.summary.COLUMNS`);
3. each identified pack's health (:mod:`planner.fleet.health`), and a pack file per pack in
   ``DIR/packs/`` carrying its present state (``model.fade_per_cycle`` and ``cycle``,
   δ calibrated on the pack's flights) that ``check --battery`` and ``select`` read;
4. each aircraft calibrated on the fleet's flights and scored on held-out ones
   (:mod:`planner.fleet.calibrate`): ``DIR/aircraft/<key>.yaml``, fitted on the thinned
   records kept in ``DIR/samples.parquet``;
5. ``DIR/report.md`` and its figures (:mod:`planner.fleet.report`), with ``diagnose``
   (docs/commands.md) run on the :data:`DIAGNOSE_WORST` worst flights.

Pack identity: the log's battery serial where the reader gives one (``battery_serial``
in the metadata), else the ``--packs`` CSV (columns ``log``, ``pack``, optionally
``cycle`` and ``aircraft``; ``log`` is the file name), else ``unknown``. Aircraft: the
CSV's ``aircraft``, else the only one, else the one of the log's vehicle type
(:func:`planner.fleet.summary.choose_aircraft`).

Every input passes :func:`planner.io.files.input_path`; every output goes through
:mod:`planner.io.files`, and ``DIR`` may not contain an input file.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
import os
import signal
import sys
import threading
import time
import uuid
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

import pandas as pd

from planner.io import files
from planner.errors import InputError
from planner.fleet.health import RETIRE_DEFAULT, PackHealth, pack_health
from planner.fleet.summary import (
    COLUMNS,
    content_hash,
    diagnose_log,
    safe_stem,
    summarise_log,
    to_frame,
)
from planner.parameters import Aircraft

__all__ = [
    "BATCH_MAX",
    "LOG_SUFFIXES",
    "SAMPLES_NAME",
    "TABLE_NAME",
    "FleetInterrupted",
    "FleetResult",
    "PackEntry",
    "batch_size",
    "collect_logs",
    "fleet_models",
    "log_items",
    "read_pack_map",
    "run_fleet",
    "summarise_all",
]

#: Files a folder is searched for.
LOG_SUFFIXES = (".bin", ".px4log", ".tlog", ".ulg")
#: The flight table in the output folder.
TABLE_NAME = "flights.parquet"
#: The flights' thinned records, for the aircraft calibration (:mod:`planner.fleet.calibrate`).
SAMPLES_NAME = "samples.parquet"
#: Interval at which a running fleet writes its table (an interrupted run keeps it). [s]
CHECKPOINT_S = 60.0
#: Worst flights (largest charge error) diagnosed for the report.
DIAGNOSE_WORST = 5
#: Most logs in one Dask task (:func:`batch_size`): on 1 000 small generated logs 32 a task
#: scale 1.8× from 1 to 2 workers where 16 gave 1.65× (benchmarks/bench_fleet.py).
BATCH_MAX = 32
#: Flights ahead in which a pack's retirement is flagged (``--within``). [flights]
WITHIN_DEFAULT = 50
#: What the fleet's files are called in messages (the output folder's).
OUTPUT = "fleet output"
#: The ``pack_id_source`` of a pack named by the packs CSV.
PACK_MAP = "packs CSV"


@dataclass
class FleetResult:
    """What a fleet run did and found.

    Attributes
    ----------
    table : DataFrame
        Every flight in ``DIR/flights.parquet`` after the run (old and new rows).
    processed, skipped : int
        Logs summarised by this run; logs already in the table (not read again).
    failed : list of (str, str)
        This run's failed logs and their one-line reasons.
    health : list of PackHealth
    pack_files : dict
        Pack id → the pack file written.
    outputs : list of Path
    elapsed_s : float
        Wall time of the Dask part. [s]
    notes : list of str
    diagnoses : dict
        Log → one line of ``diagnose`` for the worst flights.
    calibrations : list of AircraftCalibration
        Each aircraft calibrated on the fleet, scored on held-out flights.
    not_replayable : list of (str, str)
        This run's logs that were read but cannot be replayed (no current sensor).
    left_out : list of (str, str, str)
        This run's logs that were read but left out of the accuracy and the calibration:
        (log, status, reason) with status ``mismatch`` (the log's vehicle type, cells or
        mass class are not the aircraft's or pack's it is flown with) or ``not airborne``.
    """

    table: pd.DataFrame
    processed: int
    skipped: int
    failed: list[tuple[str, str]]
    health: list[PackHealth]
    pack_files: dict[str, Path] = field(default_factory=dict)
    outputs: list[Path] = field(default_factory=list)
    elapsed_s: float = 0.0
    notes: list[str] = field(default_factory=list)
    diagnoses: dict[str, str] = field(default_factory=dict)
    calibrations: list = field(default_factory=list)
    not_replayable: list[tuple[str, str]] = field(default_factory=list)
    left_out: list[tuple[str, str, str]] = field(default_factory=list)

    def count(self, status: str) -> int:
        """This run's rows of ``status`` among :attr:`left_out`."""
        return sum(st == status for _, st, _ in self.left_out)


class FleetInterrupted(KeyboardInterrupt):
    """Ctrl-C during a fleet run, after the table was written: ``kept`` flights (status
    ``ok``) are in ``table``; a rerun of the same command reads only the other logs."""

    def __init__(self, kept: int, table: Path):
        super().__init__(f"{kept} flights kept in {table}")
        self.kept, self.table = kept, table


def collect_logs(paths) -> list[Path]:
    """The log files of ``paths``: files as given, folders searched recursively for
    :data:`LOG_SUFFIXES` (sorted). Each is checked and recorded as an input."""
    out: list[Path] = []
    for raw in paths:
        p = Path(raw)
        if p.is_dir():
            found = sorted(q for q in p.rglob("*") if q.is_file()
                           and q.name.lower().endswith(LOG_SUFFIXES))
            if not found:
                raise InputError(f"{p}: a folder with no log files (expected "
                                 f"{', '.join(LOG_SUFFIXES)})")
            out += found
        else:
            out.append(p)
    seen: set[str] = set()
    logs = []
    for p in out:
        real = os.path.realpath(p)
        if real in seen:
            continue
        seen.add(real)
        logs.append(files.input_path(p, "log", "log file"))
    return logs


class PackEntry(NamedTuple):
    """One row of the ``--packs`` CSV: the pack flown (None: the log's own serial), its
    cycle count (None: not given) and the aircraft key (None: not given)."""

    pack: str | None
    cycle: float | None = None
    aircraft: str | None = None


def read_pack_map(path: str | os.PathLike, aircraft: dict | None = None
                  ) -> dict[str, PackEntry]:
    """``--packs`` CSV: log file name → :class:`PackEntry`.

    Columns ``log`` (required, the file name), ``pack`` and ``aircraft`` (at least one of
    them per row), ``cycle`` (optional, a whole number ≥ 0: the pack's charge-cycle count at
    that flight). ``aircraft``: key → Aircraft of the run; an ``aircraft`` value is a key or
    the ``name`` of one of them (the key is kept).
    """
    text = files.read_text(path, "table", "pack map CSV").removeprefix("\ufeff")  # Excel's BOM
    reader = csv.DictReader(io.StringIO(text))
    cols = [c.strip() for c in (reader.fieldnames or [])]
    if "log" not in cols or not {"pack", "aircraft"} & set(cols):
        raise InputError(f"{path}: expected a CSV with columns log,pack[,cycle][,aircraft]; "
                         f"got {','.join(cols) or 'no header'}")
    names = {}
    for key, a in (aircraft or {}).items():
        names.setdefault(key, key)
        if a is not None:
            names.setdefault(a.name, key)
    out: dict[str, PackEntry] = {}
    for k, row in enumerate(reader, start=2):
        row = {(a or "").strip(): (b or "").strip() for a, b in row.items() if a}
        log, pack, craft = row.get("log", ""), row.get("pack", ""), row.get("aircraft", "")
        if not log or not (pack or craft):
            raise InputError(f"{path}: row {k}: expected a log file name and a pack id or an "
                             f"aircraft, got log={log!r} pack={pack!r}")
        cycle = None
        if row.get("cycle"):
            try:
                cycle = float(row["cycle"])
            except ValueError:
                cycle = math.nan
            if not (math.isfinite(cycle) and cycle >= 0 and cycle.is_integer()):
                raise InputError(f"{path}: row {k}: cycle must be a whole number ≥ 0, got "
                                 f"{row['cycle']!r}")
        if craft and aircraft is not None:
            if craft not in names:
                raise InputError(f"{path}: row {k}: aircraft {craft!r} is none of the "
                                 f"aircraft given (expected one of {', '.join(aircraft)})")
            craft = names[craft]
        name = Path(log).name
        if name in out and (out[name].pack or "") != pack:
            raise InputError(f"{path}: row {k}: {name} is given two packs "
                             f"({out[name].pack}, {pack})")
        out[name] = PackEntry(pack or None, cycle, craft or None)
    return out


def _check_out_dir(out_dir: Path) -> Path:
    out = out_dir.resolve()
    if out.exists() and not out.is_dir():
        raise InputError(f"{out_dir}: not a folder (expected the output folder)")
    if not out.parent.is_dir():
        raise InputError(f"{out_dir}: folder {out.parent} does not exist (expected the "
                         "output folder in an existing one)")
    for name in files.inputs():
        real = Path(os.path.realpath(name))
        if real == out or out in real.parents:
            raise InputError(f"{out_dir}: the output folder contains the input file {name}; "
                             "outputs are never written among the inputs, expected another "
                             "folder")
    return out


def _read_parquet(path: Path, what: str) -> pd.DataFrame | None:
    """A table a previous run wrote into the output folder (None when there is none)."""
    if not path.exists():
        return None
    p = files.own_output_path(path, "table", what)
    try:
        return pd.read_parquet(p)
    except Exception as exc:  # noqa: BLE001 - pyarrow's errors are many
        raise InputError(f"{path}: not a readable {what} ({type(exc).__name__}); move "
                         "it away or give another output folder") from None


def _read_table(path: Path) -> pd.DataFrame | None:
    old = _read_parquet(path, "fleet table")
    if old is None:
        return None
    missing = [c for c in COLUMNS if c not in old.columns]
    if missing:
        raise InputError(f"{path}: not a fleet table of this version (no column "
                         f"{', '.join(missing[:3])}); move it away or give another output "
                         "folder")
    return to_frame(old[list(COLUMNS)].to_dict("records"))


def _write_table(path: Path, table: pd.DataFrame) -> None:
    path.parent.mkdir(exist_ok=True)
    with files.output_file(path, OUTPUT) as tmp:
        table.to_parquet(tmp, index=False)


def _merge(old: pd.DataFrame | None, new: pd.DataFrame) -> pd.DataFrame:
    """Old and new rows: one row per flight (an ok row per content hash; a failed log's
    latest row per file)."""
    frames = [f for f in (old, new) if f is not None and len(f)]
    if not frames:
        return new
    both = pd.concat(frames, ignore_index=True)
    ok = both[both["status"] == "ok"].drop_duplicates("sha256", keep="first")
    bad = both[both["status"] != "ok"]
    bad = bad[~bad["sha256"].isin(ok["sha256"])].drop_duplicates("log", keep="last")
    return pd.concat([ok, bad], ignore_index=True)


class _Progress:
    """One progress line on standard error (rewritten in place on a terminal)."""

    def __init__(self, total: int, stream=None):
        self.total, self.stream = total, stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()
        self.every = max(1, total // 10)
        self.shown = 0

    def update(self, done: int, failed: int, skipped: int) -> None:
        if not self.tty and done - self.shown < self.every and done != self.total:
            return
        self.shown = done
        dt = time.perf_counter() - self.t0
        rate = (done - skipped) / dt if dt > 0 else 0.0
        line = (f"fleet: {done}/{self.total} logs, {failed} failed, {skipped} already in "
                f"the table, {rate:.1f} logs/s")
        end = "" if self.tty and done != self.total else "\n"
        print(("\r" if self.tty else "") + line, end=end, file=self.stream, flush=True)


def _client(workers: int | None, scheduler: str | None):
    from dask.distributed import Client, LocalCluster

    if scheduler:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"{scheduler}: cannot connect to the Dask scheduler ({exc})") \
                from None
    # the worker processes ignore Ctrl-C: SIGINT is ignored while they start, and an
    # ignored signal stays ignored in the processes started then (fork and exec keep it);
    # the terminal sends Ctrl-C to the whole process group, and the run stops its workers
    # itself. A Ctrl-C in the seconds the cluster takes to start is therefore not seen.
    # without a dashboard the scheduler still serves its health routes, on port 8787 or,
    # taken by another cluster, any free port: that is no news to the user either
    with _sigint_ignored(), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Port 8787 is already in use")
        cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1,
                               threads_per_worker=1, processes=True, dashboard_address=None)
    try:
        return Client(cluster), cluster
    except KeyboardInterrupt:
        _close_quietly(None, cluster)
        raise


@contextlib.contextmanager
def _sigint_ignored():
    """SIGINT ignored in this block (in the main thread; elsewhere nothing changes)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


#: Loggers silenced while an interrupted run's own cluster is closed.
_QUIET_LOGGERS = ("distributed", "tornado", "asyncio")


def _silence_logs() -> list[int]:
    """Silence :data:`_QUIET_LOGGERS` in this process: their former levels."""
    import logging

    loggers = [logging.getLogger(n) for n in _QUIET_LOGGERS]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    return levels


def _close_quietly(client, cluster) -> None:
    """Close the client and the local cluster without Dask's log lines: the workers and
    their nannies stop mid-task and lose the scheduler, which is expected after Ctrl-C,
    so their loggers are silenced first (in their own processes), then this one's."""
    import logging

    with _sigint_ignored():
        if client is not None and cluster is not None:
            for nanny in (False, True):
                # a worker already gone has nothing to say
                with contextlib.suppress(Exception):
                    client.run(_silence_logs, nanny=nanny)
        levels = _silence_logs()
        try:
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
        finally:
            for name, level in zip(_QUIET_LOGGERS, levels):
                logging.getLogger(name).setLevel(level)


def _summarise_batch(items, models, samples=False):
    """:func:`summarise_log` on each item of :func:`log_items`: the rows."""
    return [summarise_log(path, pack_id, source, cycle, models=models, aircraft_key=key,
                          samples=samples)
            for path, pack_id, source, cycle, key in items]


def fleet_models(aircraft=None, pack=None) -> dict:
    """Aircraft key → (Aircraft or None, pack or None) from an Aircraft (key: its name) or
    a mapping key → Aircraft, and a pack or a mapping key → pack (None: the literature
    model of each log's cell count)."""
    if aircraft is None or isinstance(aircraft, Aircraft):
        key = aircraft.name if aircraft is not None else ""
        return {key: (aircraft, pack.get(key) if isinstance(pack, dict) else pack)}
    return {k: (a, pack.get(k) if isinstance(pack, dict) else pack)
            for k, a in aircraft.items()}


def _hash_batch(paths):
    """The content hash of each file ("" for a file that cannot be read)."""
    out = []
    for path in paths:
        try:
            out.append(content_hash(path))
        except OSError:
            out.append("")
    return out


def batch_size(logs: int, workers: int) -> int:
    """Logs per Dask task: about 8 tasks per worker (the load stays balanced to the end),
    at most :data:`BATCH_MAX` (the progress line moves) and at least 1. Each task costs the
    scheduler a few milliseconds, as much as reading a small log: batches amortise it."""
    return max(1, min(BATCH_MAX, math.ceil(logs / (8 * max(workers, 1)))))


def log_items(logs: list[Path], pack_map: dict | None) -> list[tuple]:
    """``(path, pack id, id source, cycle, aircraft key)`` of each log from the
    ``--packs`` map: the arguments of :func:`summarise_log`."""
    items = []
    for p in logs:
        entry = (pack_map or {}).get(Path(p).name) or PackEntry(None)
        items.append((str(p), entry.pack, PACK_MAP if entry.pack else "unknown",
                      entry.cycle, entry.aircraft))
    return items


def summarise_all(logs: list[Path], *, aircraft=None, pack=None, pack_map: dict | None,
                  skip: set[str], client, progress=None, batch: int | None = None,
                  on_batch=None, models: dict | None = None, samples: bool = False
                  ) -> tuple[list[dict], int]:
    """Every log through :func:`summarise_log` on the Dask ``client``, ``batch`` logs per
    task (default :func:`batch_size`): (rows, skipped). ``on_batch(rows)`` is called with
    the rows so far after every finished task. ``models`` (:func:`fleet_models`) instead of
    ``aircraft`` and ``pack``; ``samples``: each row carries its calibration samples."""
    from dask.distributed import as_completed

    models = models if models is not None else fleet_models(aircraft, pack)
    items = log_items(logs, pack_map)
    workers = len(client.scheduler_info().get("workers", {})) or 1
    size = batch or batch_size(len(items), workers)
    run = uuid.uuid4().hex[:12]         # keys unique to this call: a rerun on the same client
    skipped = 0
    if skip:
        # a rerun: the workers hash the logs, the ones already in the table are not read
        paths = [it[0] for it in items]
        chunks = [paths[i:i + size] for i in range(0, len(paths), size)]
        hashes = client.gather(client.map(
            _hash_batch, chunks, key=[f"fleet-hash-{run}-{k}" for k in range(len(chunks))],
            pure=False))
        known = [h in skip for chunk in hashes for h in chunk]
        skipped = sum(known)
        items = [it for it, seen in zip(items, known) if not seen]
    chunks = [items[i:i + size] for i in range(0, len(items), size)]
    # the aircraft and the packs (a few kB) travel with each task: no scattered data to lose
    futures = client.map(_summarise_batch, chunks,
                         key=[f"fleet-{run}-{k}-{Path(c[0][0]).name}"
                              for k, c in enumerate(chunks)],
                         pure=False, models=models, samples=samples)
    rows, failed, done = [], 0, skipped
    if progress is not None and skipped:
        progress.update(done, failed, skipped)
    for fut in as_completed(futures):
        for row in fut.result():
            done += 1
            rows.append(row)
            failed += row["status"] == "failed"
        if on_batch is not None:
            on_batch(rows)
        if progress is not None:
            progress.update(done, failed, skipped)
        fut.release()
    order = {str(p): k for k, p in enumerate(logs)}
    rows.sort(key=lambda r: order.get(r["log"], len(order)))
    return rows, skipped


def worst_flights(table: pd.DataFrame, count: int) -> pd.DataFrame:
    """The ``count`` flights with the largest absolute charge error."""
    ok = table[table["status"] == "ok"]
    order = ok["charge_error_pct"].abs().sort_values(ascending=False, na_position="last")
    return ok.loc[order.index[:count]]


def diagnose_worst(table: pd.DataFrame, client, *, aircraft=None, pack=None,
                   count: int | None = None, models: dict | None = None) -> dict[str, str]:
    """:func:`planner.fleet.summary.diagnose_log` on the worst flights, one task each, each
    with the aircraft that flew it: log → one line."""
    models = models if models is not None else fleet_models(aircraft, pack)
    worst = worst_flights(table, DIAGNOSE_WORST if count is None else count)
    logs = [str(p) for p in worst["log"]]
    if not logs:
        return {}
    run = uuid.uuid4().hex[:12]
    futures = []
    for k, (log, key) in enumerate(zip(logs, worst["aircraft"])):
        craft, flown = models.get(key, (None, None)) if isinstance(key, str) else (None, None)
        futures.append(client.submit(diagnose_log, log, key=f"fleet-diagnose-{run}-{k}",
                                     pure=False, aircraft=craft, pack=flown))
    return dict(zip(logs, client.gather(futures)))


def _pack_file_name(pack_id: str) -> str:
    return f"{safe_stem(pack_id, 'pack')}.yaml"


def write_pack_files(health: list[PackHealth], pack, folder: Path
                     ) -> tuple[dict[str, Path], list[str]]:
    """A pack file per pack with a fade fit: ``pack`` (a BatteryPack, or a function of the
    pack id giving the new pack of the aircraft that flew it) with δ calibrated on the
    pack's flights (:math:`\\delta a^{-\\beta}`), ``fade_per_cycle`` :math:`\\varphi` and
    ``cycle`` the next flight's (module notes of :mod:`planner.fleet.health`)."""
    import yaml

    from planner.parameters.pack import MODEL_KEYS

    lo, hi = MODEL_KEYS["fade_per_cycle"].low, MODEL_KEYS["fade_per_cycle"].high
    written, notes = {}, []
    for h in health:
        if not (math.isfinite(h.scale_new) and math.isfinite(h.fade_per_cycle)):
            notes.append(f"pack {h.pack_id}: {h.flights} flight(s), too few to fit its fade; "
                         "no pack file")
            continue
        phi = min(max(h.fade_per_cycle, lo), hi)
        if phi != h.fade_per_cycle:
            notes.append(f"pack {h.pack_id}: fitted fade {h.fade_per_cycle:.4g}/cycle is "
                         f"outside the pack file's [{lo}, {hi}]; written as {phi:g}")
        ref = pack(h.pack_id) if callable(pack) else pack
        m = ref.model
        model = replace(m, delta=m.delta * h.scale_new ** (-m.beta), literature=False,
                        fade_per_cycle=phi, cycle=h.last_cycle + 1.0,
                        source=f"endurance fleet: {h.flights} flights of pack {h.pack_id}")
        named = replace(ref, name=f"{ref.name} (pack {h.pack_id})", model=model)
        mapping = named.to_mapping(folder=folder)
        mapping["source"] = (f"endurance fleet on {h.flights} flights: fade "
                             f"{h.fade_per_cycle:.3g} ± {h.fade_per_cycle_se:.2g} per cycle, "
                             f"state of health {100 * h.soh:.1f} % at cycle {h.last_cycle:.0f}"
                             "; model.cycle is the next flight's")
        name = _pack_file_name(h.pack_id)
        taken = {p.name for p in written.values()}
        stem, k = name[:-5], 2
        while name in taken:                     # "A/1" and "A_1" are two packs
            name, k = f"{stem}-{k}.yaml", k + 1
        path = folder / name
        files.write_text(path, yaml.safe_dump(mapping, sort_keys=False, allow_unicode=True),
                         OUTPUT)
        written[h.pack_id] = path
    return written, notes


def _samples_table(old: pd.DataFrame | None, rows: list[dict], keep: set[str]) -> pd.DataFrame:
    """The calibration samples of the flights in ``keep`` (content hashes): this run's rows'
    and, for the flights read before, the old table's."""
    parts = [r["_samples"].assign(sha256=r["sha256"]) for r in rows
             if r.get("status") == "ok" and r.get("_samples") is not None]
    new = {r["sha256"] for r in rows}
    if old is not None and "sha256" in old:
        parts.insert(0, old[old["sha256"].isin(keep - new)])
    if not parts:
        return pd.DataFrame({"sha256": pd.Series(dtype="string")})
    out = pd.concat(parts, ignore_index=True)
    out["sha256"] = out["sha256"].astype("string")
    return out


def _pack_aircraft(table: pd.DataFrame) -> dict[str, str]:
    """Pack id → the aircraft that flew most of its flights."""
    ok = table[(table["status"] == "ok") & table["aircraft"].notna()]
    return {str(p): str(g.mode().iloc[0]) for p, g in ok.groupby("pack_id")["aircraft"]}


def run_fleet(paths, *, out_dir: str | os.PathLike, aircraft=None, pack=None,
              pack_map: dict | None = None, workers: int | None = None,
              scheduler: str | None = None, client=None, retire: float = RETIRE_DEFAULT,
              within: float = WITHIN_DEFAULT, progress=True,
              checkpoint_s: float | None = None, calibrate: bool = True,
              figures=None) -> FleetResult:
    """Run a fleet (module notes).

    ``aircraft``: an Aircraft (its key in the table is its name) or a mapping key →
    Aircraft (a fleet of several); ``pack``: the new pack of every aircraft, or a mapping
    key → pack, or None (the literature model of each log's cell count; no pack files).
    ``client``: an existing Dask client (then neither ``workers`` nor ``scheduler`` is
    used and the client is left open). ``progress``: a progress line on standard error
    (True), none (False) or an object with ``update(done, failed, skipped)``. The table
    is written every ``checkpoint_s`` seconds (default :data:`CHECKPOINT_S`) and when
    the run is interrupted. ``calibrate``: calibrate each aircraft on the fleet
    (:mod:`planner.fleet.calibrate`). ``figures``: draws the report's figures
    (:func:`planner.fleet.report.write_report`; the command line passes
    :func:`planner.cli.plots.fleet.write_figures`); None: a text report. ``retire``:
    the state of health at retirement [unitless]; ``within``: flights ahead in which a
    retirement is flagged.

    Raises
    ------
    InputError
        No logs, ``out_dir`` among the inputs or unusable, or every log failed (naming
        each with its reason).
    FleetInterrupted
        Ctrl-C (a KeyboardInterrupt): the table is written first, and the exception says
        how many flights it holds; the run's own cluster is closed without its workers'
        log lines.
    """
    models = fleet_models(aircraft, pack)
    logs = collect_logs(paths)
    if not logs:
        raise InputError("no log files given")
    out = _check_out_dir(Path(out_dir))
    store = _Store(out, calibrate)
    own = client is None
    cluster = None
    if own:
        try:
            client, cluster = _client(workers, scheduler)
        except KeyboardInterrupt:
            raise _interrupted(store, []) from None
    if progress is True:
        progress = _Progress(len(logs))
    quiet = False
    try:
        result, rows = _summarise_and_diagnose(
            logs, models, pack_map, store, client, progress,
            CHECKPOINT_S if checkpoint_s is None else checkpoint_s)
    except KeyboardInterrupt:
        quiet = True
        raise
    finally:
        if own:
            if quiet:
                _close_quietly(client, cluster)
            else:
                client.close()
                if cluster is not None:
                    cluster.close()
    from planner.fleet.report import write_report

    try:
        if calibrate:
            _calibrate_aircraft(result, models, store, rows, out)
        _write_table(store.table_path, result.table)
        _pack_health(result, models, out, retire)
        result.outputs += write_report(result, out, retire=retire, within=within,
                                       figures=figures)
    except KeyboardInterrupt:
        raise _interrupted(store, rows) from None
    return result


class _Store:
    """The tables in the output folder: the flight table and (with ``calibrate``) the
    calibration samples, as a previous run left them; :meth:`save` checkpoints a run."""

    def __init__(self, out: Path, calibrate: bool):
        self.table_path = out / TABLE_NAME
        self.samples_path = out / SAMPLES_NAME
        self.calibrate = calibrate
        self.old = _read_table(self.table_path)
        self.old_samples = (_read_parquet(self.samples_path, "fleet samples table")
                            if calibrate else None)
        #: Content hashes of the flights already in the table (not read again).
        self.skip = (set(self.old.loc[self.old["status"] == "ok", "sha256"])
                     if self.old is not None else set())

    def samples(self, rows: list[dict], table: pd.DataFrame) -> pd.DataFrame:
        """The calibration samples of the flights of ``table`` (old and new)."""
        return _samples_table(self.old_samples, rows,
                              set(table.loc[table["status"] == "ok", "sha256"]))

    def save(self, rows: list[dict]) -> None:
        """Write the table (and the samples) with the rows so far."""
        merged = _merge(self.old, to_frame(rows))
        if self.calibrate:
            _write_table(self.samples_path, self.samples(rows, merged))
        _write_table(self.table_path, merged)


def _summarise_and_diagnose(logs, models, pack_map, store: _Store, client, progress,
                            checkpoint_s: float) -> tuple[FleetResult, list[dict]]:
    """Every log through :func:`summarise_all` on the Dask ``client`` (the table written
    every ``checkpoint_s`` seconds [s] and when interrupted), then ``diagnose`` on the
    worst flights: the result so far, and this run's rows."""
    t0 = time.perf_counter()
    so_far: list[dict] = []
    last = [t0]

    def save(rows, every: float = checkpoint_s) -> None:
        """Write the table with the rows so far (every ``every`` seconds): an interrupted
        run keeps what it finished, and its rerun reads only the rest."""
        so_far[:] = rows
        now = time.perf_counter()
        if rows and any(r["status"] == "ok" for r in rows) and now - last[0] >= every:
            store.save(rows)
            last[0] = now

    try:
        rows, skipped = summarise_all(
            logs, models=models, pack_map=pack_map, skip=store.skip, client=client,
            progress=progress or None, on_batch=save, samples=store.calibrate)
    except KeyboardInterrupt:
        raise _interrupted(store, so_far) from None
    elapsed = time.perf_counter() - t0
    failed = [(r["log"], r["error"]) for r in rows if r["status"] == "failed"]
    not_replayable = [(r["log"], r["error"]) for r in rows
                      if r["status"] == "not replayable"]
    left_out = [(r["log"], r["status"], r["error"]) for r in rows
                if r["status"] in ("mismatch", "not airborne")]
    if rows and len(failed) == len(rows) and not skipped:
        listed = "; ".join(f"{err}" for _, err in failed[:5])
        raise InputError(f"all {len(failed)} logs failed: {listed}"
                         + (" …" if len(failed) > 5 else ""))
    table = _merge(store.old, to_frame(rows))
    try:
        diagnoses = diagnose_worst(table, client, models=models)
    except KeyboardInterrupt:
        raise _interrupted(store, rows) from None
    result = FleetResult(table=table, processed=len(rows), skipped=skipped, failed=failed,
                         health=[], outputs=[store.table_path], elapsed_s=elapsed,
                         diagnoses=diagnoses, not_replayable=not_replayable,
                         left_out=left_out)
    return result, rows


def _interrupted(store: _Store, rows: list[dict]) -> FleetInterrupted:
    """Write the table with this run's ``rows`` (Ctrl-C): the exception that says so."""
    with _sigint_ignored():                 # a second Ctrl-C does not cut the table short
        if rows:
            store.save(rows)
        kept = _read_table(store.table_path)
    return FleetInterrupted(0 if kept is None else int((kept["status"] == "ok").sum()),
                            store.table_path)


def _calibrate_aircraft(result: FleetResult, models: dict, store: _Store, rows, out: Path
                        ) -> None:
    """Write the calibration samples and calibrate each aircraft on them
    (:mod:`planner.fleet.calibrate`), writing ``aircraft/<key>.yaml``."""
    from planner.fleet.calibrate import calibrate_aircraft, write_aircraft_file

    samples = store.samples(rows, result.table)
    _write_table(store.samples_path, samples)
    result.outputs.append(store.samples_path)
    for key, (craft, flown) in models.items():
        if craft is None:
            continue
        cal = calibrate_aircraft(key, samples, result.table, craft, flown)
        if cal.aircraft is not None:
            result.outputs.append(write_aircraft_file(cal, out / "aircraft"))
        result.calibrations.append(cal)


def _pack_health(result: FleetResult, models: dict, out: Path, retire: float) -> None:
    """Each pack's health (:func:`planner.fleet.health.pack_health`) and, for a pack whose
    aircraft has a pack file, its present-state pack file in ``packs/``."""
    table = result.table
    owner = _pack_aircraft(table)

    def new_pack(pack_id: str):
        """The new pack of the aircraft that flew ``pack_id`` (None without one)."""
        key = owner.get(pack_id)
        if key in models:
            return models[key][1]
        return next((p for _, p in models.values() if p is not None), None) \
            if len(models) == 1 else None

    nominal = {}
    for pid in table.loc[table["status"] == "ok", "pack_id"].dropna().unique():
        ref = new_pack(str(pid))
        if ref is not None:
            nominal[str(pid)] = ref.capacity_mah
    result.health = pack_health(table, retire=retire, nominal_mah=nominal, aircraft=owner)
    if not result.health:
        return
    with_pack = [h for h in result.health if new_pack(h.pack_id) is not None]
    if len(with_pack) < len(result.health):
        result.notes.append("no pack file (no new pack given, and the aircraft file names "
                            "no battery) for "
                            + ", ".join(h.pack_id for h in result.health
                                        if h not in with_pack))
    if with_pack:
        (out / "packs").mkdir(exist_ok=True)
        result.pack_files, notes = write_pack_files(with_pack, new_pack, out / "packs")
        result.notes += notes
        result.outputs += list(result.pack_files.values())

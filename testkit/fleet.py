"""A generated fleet: three aircraft flying twelve packs that age at known rates, as logs.

Used by ``tests/test_fleet.py`` and ``benchmarks/bench_fleet.py``. Every flight is flown
by :func:`testkit.flight.simulate_flight` (the planner's own models, so nothing here
validates a model; it checks that ``endurance fleet`` recovers what was put in) and
written by :func:`testkit.writers.write_log` in turn as ``.bin``, ``.tlog`` and ``.ulg``.

* **Aircraft.** The 3DR Solo and the 7-inch quadcopter (multirotors) and the Skywalker X8
  (fixed wing) of ``aircraft/``. Each is flown as a *true* aircraft that differs from its
  file (:data:`TRUTH`: more drag, a lower efficiency, as a real airframe differs from its
  data sheet), so a calibration on the fleet has something to find.
* **Packs.** Four per aircraft, of the aircraft's pack type (:data:`PACKS`). A pack
  ageing at ``φ`` per cycle draws ``(1 + φ n)`` times the new pack's charge for the same
  energy at cycle ``n``: the simulated current is multiplied by that factor and the
  voltage divided by it (the power, and so the flight, unchanged), with a flight-to-flight
  scatter of :data:`SCATTER` (temperature, charge at take-off). The step resistance of
  such a log reads R/s², an artefact of the injection.
* **Identity.** Pack ``4242`` of the Solo is a smart battery: its serial is in every log
  (ULog ``battery_status.serial_number`` with its cycle count, ``BATT_SERIAL_NUM`` in the
  others); every other pack is named in the ``--packs`` CSV, some with their cycle count.
  The CSV names the aircraft of the multirotor flights (two multirotors could have flown
  them); the X8's flights are left to the log's vehicle type.
* **Order.** Each pack flies one flight a day from its own first day; the files are
  named in a shuffled order, so a pack's flights are put in order by the cycles given or
  by the logs' start times, never by the file names.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from planner.physics.mission import Environment, Leg, Mission
from planner.parameters import Aircraft, BatteryPack, load_aircraft_and_battery

REPO = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class FleetPack:
    """One pack of the generated fleet.

    Attributes
    ----------
    name : str
    aircraft : str
        Key of :data:`AIRCRAFT` it flies on.
    fade_per_cycle : float
        φ. [1/cycle]
    first_cycle : int
        Its cycle count at its first flight in the fleet. [cycles]
    cycles_in_csv : bool
        The ``--packs`` CSV gives each flight's cycle (else the order of start times).
    serial : int or None
        A smart battery's serial number, written into its logs.
    """

    name: str
    aircraft: str
    fade_per_cycle: float
    first_cycle: int = 0
    cycles_in_csv: bool = False
    serial: int | None = None

    def retires_within(self, flights: int, flights_per_pack: int, retire: float = 0.8
                       ) -> bool:
        """The truth of ``PackHealth.retires_within`` after the pack's last flight."""
        if self.fade_per_cycle <= 0:
            return False
        last = self.first_cycle + flights_per_pack - 1
        return (1.0 / retire - 1.0) / self.fade_per_cycle - last <= flights


#: Aircraft key → aircraft file.
AIRCRAFT = {"solo_survey": "aircraft/solo_survey.yaml", "quad_7in": "aircraft/quad_7in.yaml",
            "x8_mapper": "aircraft/x8_mapper.yaml"}
#: Aircraft key → the true aircraft's parameters where they differ from the file.
TRUTH = {"solo_survey": {"drag_area_m2": 1.5, "efficiency": 0.92},
         "quad_7in": {"drag_area_m2": 1.4},
         "x8_mapper": {"cd0": 1.25}}
#: The packs. A pack whose fade is not given by cycles starts at cycle 0 (its first flight
#: in the fleet is its first cycle). Chosen so that the packs flagged for retirement
#: within 50 flights (S4, Q2, Q4, X3) and the others are at least 6 flights from the line.
PACKS = (
    FleetPack("4242", "solo_survey", 0.0, serial=4242),
    FleetPack("S2", "solo_survey", 0.002),
    FleetPack("S3", "solo_survey", 0.0025, 5, True),
    FleetPack("S4", "solo_survey", 0.008, 20, True),
    FleetPack("Q1", "quad_7in", 0.001),
    FleetPack("Q2", "quad_7in", 0.004, 40, True),
    FleetPack("Q3", "quad_7in", 0.0015, 10, True),
    FleetPack("Q4", "quad_7in", 0.010),
    FleetPack("X1", "x8_mapper", 0.0),
    FleetPack("X2", "x8_mapper", 0.002, 10, True),
    FleetPack("X3", "x8_mapper", 0.005, 30, True),
    FleetPack("X4", "x8_mapper", 0.003),
)
#: Relative flight-to-flight scatter of the charge per energy. [unitless]
SCATTER = 0.005
#: Log formats, in turn.
FORMATS = (".bin", ".tlog", ".ulg")
#: The first flight's UTC (2024-03-01 08:00 UTC). [s since 1970]
START_UNIX = 1_709_280_000.0
DAY_S = 86_400.0


@dataclass
class GeneratedFleet:
    """The folder of a generated fleet.

    Attributes
    ----------
    logs : Path
        The folder with the logs.
    packs_csv : Path
        The ``--packs`` CSV (columns ``log, pack, cycle, aircraft``).
    truth : DataFrame
        One row per log: ``log`` (file name), ``aircraft``, ``pack``, ``cycle``,
        ``scale`` (the charge factor injected), ``format``, ``start_unix``.
    flights_per_pack : int
    """

    logs: Path
    packs_csv: Path
    truth: pd.DataFrame
    flights_per_pack: int


def aircraft_files() -> dict[str, Path]:
    """Aircraft key → the aircraft file of the repository."""
    return {k: REPO / v for k, v in AIRCRAFT.items()}


def true_aircraft(key: str) -> tuple[Aircraft, BatteryPack]:
    """The aircraft ``key`` as flown (:data:`TRUTH` applied to its file) and its pack."""
    from planner.identify.aircraft_fit import get_param, with_params

    aircraft, pack = load_aircraft_and_battery(aircraft_files()[key])
    values = {name: get_param(aircraft, name) * factor
              for name, factor in TRUTH[key].items()}
    return with_params(aircraft, values), pack


def mission(aircraft: Aircraft) -> Mission:
    """A short sortie for the aircraft: out, a hold (hover or loiter) and back."""
    if aircraft.is_multirotor:
        return Mission("fleet sortie", [
            Leg("climb", (0.0, 0.0), (0.0, 0.0), 0.0, 30.0, climb_rate_ms=2.5),
            Leg("cruise", (0.0, 0.0), (700.0, 0.0), 30.0, 30.0, speed_ms=9.0),
            Leg("hover", (700.0, 0.0), (700.0, 0.0), 30.0, 30.0, duration_s=40.0),
            Leg("cruise", (700.0, 0.0), (0.0, 0.0), 30.0, 30.0, speed_ms=6.0),
            Leg("descend", (0.0, 0.0), (0.0, 0.0), 30.0, 0.0, climb_rate_ms=1.5)])
    return Mission("fleet sortie", [
        Leg("climb", (0.0, 0.0), (0.0, 600.0), 0.0, 80.0, speed_ms=16.0, climb_rate_ms=2.5),
        Leg("cruise", (0.0, 600.0), (2500.0, 600.0), 80.0, 80.0, speed_ms=20.0),
        Leg("loiter", (2500.0, 600.0), (2500.0, 600.0), 80.0, 80.0, speed_ms=15.0,
            duration_s=60.0, loiter_radius_m=80.0),
        Leg("cruise", (2500.0, 600.0), (0.0, 600.0), 80.0, 80.0, speed_ms=16.0),
        Leg("descend", (0.0, 600.0), (0.0, 0.0), 80.0, 0.0, speed_ms=15.0,
            climb_rate_ms=2.0)])


def generate_fleet(root: str | Path, *, flights_per_pack: int = 18, rate_hz: float = 2.0,
                   seed: int = 16, packs=PACKS) -> GeneratedFleet:
    """Write the fleet's logs into ``root/logs`` and the ``--packs`` CSV into ``root``
    (module notes): ``len(packs) × flights_per_pack`` logs."""
    from testkit.flight import simulate_flight
    from testkit.writers import write_log

    root = Path(root)
    logs = root / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    flown = {key: true_aircraft(key) for key in AIRCRAFT}
    sorties = {key: mission(a) for key, (a, _) in flown.items()}
    total = len(packs) * flights_per_pack
    names = rng.permutation(total)                 # file names in no flight order
    truth, csv_rows = [], []
    k = 0
    for p_index, p in enumerate(packs):
        aircraft, pack = flown[p.aircraft]
        for j in range(flights_per_pack):
            cycle = p.first_cycle + j
            env = Environment(float(rng.uniform(0, 7)), float(rng.uniform(0, 360)), 15.0)
            rec = simulate_flight(sorties[p.aircraft], aircraft, pack, environment=env,
                                  rate_hz=rate_hz, seed=seed * 100_000 + k, experiment="f")
            s = (1.0 + p.fade_per_cycle * cycle) * (1.0 + SCATTER * rng.standard_normal())
            rec["current_a"] *= s
            rec["voltage_v"] /= s
            rec["consumed_mah"] *= s
            ext = FORMATS[k % len(FORMATS)]
            file = logs / f"flight_{names[k]:05d}{ext}"
            start = START_UNIX + (p_index + j) * DAY_S + 3600.0 * (k % 7)
            opts: dict = {"capacity_mah": pack.capacity_mah, "start_time_unix": start,
                          "vehicle_type": aircraft.type}
            if ext == ".ulg":
                opts["cells"] = pack.cells_series
            if p.serial is not None:
                if ext == ".ulg":
                    opts.update(battery_serial=p.serial, battery_cycle=cycle)
                else:
                    opts["params"] = {"BATT_SERIAL_NUM": float(p.serial)}
            write_log(rec, file, **opts)
            row = {"log": file.name, "pack": "" if p.serial is not None else p.name,
                   "cycle": str(cycle) if p.cycles_in_csv else "",
                   "aircraft": p.aircraft if aircraft.is_multirotor else ""}
            if row["pack"] or row["aircraft"]:
                csv_rows.append(row)
            truth.append({"log": file.name, "aircraft": p.aircraft, "pack": p.name,
                          "cycle": cycle, "scale": s, "format": ext[1:],
                          "start_unix": start})
            k += 1
    csv = root / "packs.csv"
    pd.DataFrame(csv_rows, columns=["log", "pack", "cycle", "aircraft"]).to_csv(csv, index=False)
    return GeneratedFleet(logs, csv, pd.DataFrame(truth), flights_per_pack)

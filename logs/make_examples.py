"""Make the example logs the repository ships: SIMULATED flights, one per log format.

Every file in ``logs/`` whose name starts with ``sim_`` is made by this script
from a shipped mission and aircraft, flown by our own models
(:func:`testkit.flight.simulate_flight`) with known "true" aircraft
parameters that differ from the aircraft file's, and written by
:mod:`testkit.writers`. Nothing here is a real flight; every file says so
inside (``MSG``/``STATUSTEXT``/logged string "SIMULATED by uav-endurance-planner",
ULog info key ``simulated``). Real logs stay in ``../shared/data/logs``.

Run from the repository root (no installation needed)::

    python logs/make_examples.py            # (re)write logs/sim_*
    python logs/make_examples.py --check    # regenerate in memory, compare with logs/
    python logs/make_examples.py --out DIR  # write elsewhere

The output is deterministic: fixed seeds, fixed start times, no clock. Another build of
numpy may round a transcendental function differently in its last bit, which moves a few
float32 values of a file by one unit in the last place: ``--check`` then says the file
has the same content (every channel within a relative 1e-6 of the shipped one) and
fails only where the content differs.

Each flight is a shortened version of its mission (the first survey lanes or
mapping line, then the mission's own ending re-anchored at the end of what
was flown), so that a file stays small (< 500 kB) at its sample rate.
Throttle is not modelled: the logs carry an illustrative throttle
``T = T_ref · (P / P_median)^(1/3)`` (rotor speed ∝ P^(1/3)), with T_ref 0.40
(multirotor) or 0.55 (fixed-wing); no model in the planner uses it.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:           # run from a fresh clone without installing
    sys.path.insert(0, str(REPO))

import numpy as np
import pandas as pd

from planner.identify.aircraft_fit import with_params
from planner.io.mission import load_mission
from planner.physics.mission import Environment, Mission
from planner.parameters import load_aircraft_and_battery
from testkit.flight import simulate_flight

#: True parameters of the simulated 3DR Solo (aircraft/solo_survey.yaml has η 0.80,
#: f 0.03 m², P_S 8 W).
SOLO_TRUTH = {"efficiency": 0.72, "drag_area_m2": 0.045, "system_power_w": 15.0}
#: True parameters of the simulated Skywalker X8 (aircraft/x8_mapper.yaml has
#: C_D0 0.0197, η 0.50, P_S 8 W; K stays the file's 0.0677).
X8_TRUTH = {"cd0": 0.024, "efficiency": 0.45, "system_power_w": 12.0}
#: Reference throttle at the flight's median power (illustrative, see the module doc).
THROTTLE_REF = {"multirotor": 0.40, "fixed_wing": 0.55}


@dataclass(frozen=True)
class Example:
    """One simulated flight and the file it is written to.

    Attributes
    ----------
    file : str
        File name in ``logs/`` (the extension picks the format).
    aircraft, mission : str
        Shipped definition files, relative to the repository root.
    legs : tuple of int
        Indices of the mission's legs flown, in order; positions and
        altitudes are chained so each leg starts where the previous ended.
    wind_ms, wind_from_deg : float
        Steady wind. [m/s], [deg, direction it blows from]
    temperature_c : float
        Air and pack temperature at the site. [°C]
    seed : int
        Seed of the turbulence and sensor noise.
    rate_hz : float
        Sample rate of the battery (and position, barometer) messages. [Hz]
    truth : dict
        True aircraft parameters the flight is simulated with.
    description : str
        One line for the README.
    """

    file: str
    aircraft: str
    mission: str
    legs: tuple[int, ...]
    wind_ms: float
    wind_from_deg: float
    temperature_c: float
    seed: int
    rate_hz: float
    truth: dict = field(default_factory=dict)
    description: str = ""


_SURVEY_LEGS = (0, 1, 2, 3, 4, 15, 16, 17)     # climb, transit, 2 lanes, hover, home, land
_MAPPING_LEGS = (0, 1, 3, 26, 27, 28)          # climb, transit, 1 mapping line, home, loiter, land

EXAMPLES = (
    Example("sim_solo_calm.bin", "aircraft/solo_survey.yaml", "missions/survey_quad.yaml",
            _SURVEY_LEGS, 1.5, 250.0, 14.0, 101, 5.0, SOLO_TRUTH,
            "3DR Solo survey in a light breeze, ArduCopter DataFlash log"),
    Example("sim_solo_windy.ulg", "aircraft/solo_survey.yaml", "missions/survey_quad.yaml",
            _SURVEY_LEGS, 8.0, 250.0, 8.0, 102, 5.0, SOLO_TRUTH,
            "3DR Solo survey in a strong wind, PX4 ULog"),
    Example("sim_solo_crosswind.tlog", "aircraft/solo_survey.yaml", "missions/survey_quad.yaml",
            _SURVEY_LEGS, 5.0, 160.0, 20.0, 103, 5.0, SOLO_TRUTH,
            "3DR Solo survey in a crosswind, ArduCopter MAVLink telemetry log"),
    Example("sim_x8_mapping.ulg", "aircraft/x8_mapper.yaml", "missions/mapping_plane.yaml",
            _MAPPING_LEGS, 6.0, 240.0, 18.0, 104, 3.0, X8_TRUTH,
            "Skywalker X8 mapping flight, PX4 fixed-wing ULog"),
)


def flown_mission(mission: Mission, legs: tuple[int, ...]) -> Mission:
    """The mission's legs ``legs`` flown one after another.

    A leg that moves keeps its end point and starts where the previous leg
    ended; a stationary leg (climb, hover, loiter, descent) is moved to that
    point. Altitudes are chained the same way.
    """
    pos, alt, out = (0.0, 0.0), 0.0, []
    for i in legs:
        leg = mission.legs[i]
        moving = leg.start_en_m != leg.end_en_m
        end = leg.end_en_m if moving else pos
        end_alt = leg.end_alt_m if leg.kind in ("climb", "descend", "cruise") else alt
        out.append(leg.with_(start_en_m=pos, end_en_m=end, start_alt_m=alt, end_alt_m=end_alt,
                             origin=f"{leg.origin} (flown part)"))
        pos, alt = end, end_alt
    return Mission(f"{mission.name} (shortened)", out, mission.environment, mission.payload_kg,
                   mission.home, mission.source)


def load(example: Example):
    """(truth aircraft, pack, flown mission, environment) of an example."""
    aircraft, pack = load_aircraft_and_battery(REPO / example.aircraft)
    mission = load_mission(REPO / example.mission, vehicle_type=aircraft.type)
    env = mission.environment
    env = Environment(example.wind_ms, example.wind_from_deg, example.temperature_c,
                      env.pressure_pa, env.site_altitude_m)
    return with_params(aircraft, example.truth), pack, flown_mission(mission, example.legs), env


def flight_record(example: Example) -> pd.DataFrame:
    """The simulated flight record of an example, with the illustrative throttle."""
    truth, pack, mission, env = load(example)
    df = simulate_flight(mission, truth, pack, environment=env, rate_hz=example.rate_hz,
                         temperature_c=example.temperature_c, seed=example.seed,
                         experiment=Path(example.file).stem)
    p = df["power_w"].to_numpy(float)
    ref = THROTTLE_REF[truth.type]
    df["throttle"] = np.clip(ref * np.cbrt(np.maximum(p, 0.0) / np.median(p)), 0.0, 1.0)
    return df


def write_example(example: Example, out_dir: Path) -> Path:
    """Simulate one example and write its log into ``out_dir``."""
    from testkit.writers import write_log

    truth, pack, mission, _ = load(example)
    df = flight_record(example)
    path = Path(out_dir) / example.file
    options = {"vehicle_type": truth.type, "capacity_mah": pack.capacity_mah,
               "home": mission.home}
    if path.suffix == ".ulg":
        options["cells"] = pack.cells_series
    if path.suffix == ".bin":
        options["resistance_ohm"] = pack.internal_resistance_ohm or 0.0
    return write_log(df, path, **options)


def same_content(a: Path, b: Path, rtol: float = 1e-6) -> bool:
    """Whether two logs decode to the same channels, every value within ``rtol`` (relative)
    of the other's: the same flight written again, up to the last bit of a float32."""
    import warnings

    from planner.io.logs import read_log

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        x, _ = read_log(a)
        y, _ = read_log(b)
    if list(x.columns) != list(y.columns) or len(x) != len(y):
        return False
    for col in x.columns:
        u, v = x[col].to_numpy(), y[col].to_numpy()
        if u.dtype.kind in "fiu" and v.dtype.kind in "fiu":
            if not np.allclose(u.astype(float), v.astype(float), rtol=rtol, atol=0.0,
                               equal_nan=True):
                return False
        elif not (x[col].astype(str) == y[col].astype(str)).all():
            return False
    return True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent,
                    help="directory to write into (default: logs/ beside this script)")
    ap.add_argument("--check", action="store_true",
                    help="regenerate into a temporary directory and compare with --out")
    args = ap.parse_args(argv)
    if args.check:
        with tempfile.TemporaryDirectory() as tmp:
            bad = []
            for ex in EXAMPLES:
                path = write_example(ex, Path(tmp))
                old = args.out / ex.file
                same = old.is_file() and old.read_bytes() == path.read_bytes()
                verdict = "identical" if same else (
                    "same content (float rounding of this numpy build)"
                    if old.is_file() and same_content(old, path) else "DIFFERS")
                print(f"{ex.file:28s} {verdict}")
                if verdict == "DIFFERS":
                    bad.append(ex.file)
        return 1 if bad else 0
    args.out.mkdir(parents=True, exist_ok=True)
    for ex in EXAMPLES:
        path = write_example(ex, args.out)
        print(f"{path}  {path.stat().st_size / 1000:.0f} kB  SIMULATED: {ex.description}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Read every real mission file of a folder and say what became of each.

The folder is ``../shared/data/missions_real`` by default: 40 mission files written by
QGroundControl, Mission Planner, MAVProxy, MAVSDK, PX4 and ArduPilot's test suites
(its ``PROVENANCE.md`` and ``SOURCES.tsv`` name each file's repository and commit). Each
file is read as ``check`` reads it, with the navigation defaults of a shipped aircraft of
its kind (``aircraft/solo_survey.yaml`` for a multirotor, ``aircraft/x8_mapper.yaml`` for
a fixed-wing or VTOL aircraft: a ``.plan``'s ``vehicleType``, else the file's origin), and
is put in one of three classes:

* **read** — the mission's legs, with the total horizontal distance flown;
* **refused with the firmware's reason** — refused for a reason a firmware or
  QGroundControl also refuses it for (:data:`FIRMWARE_REASONS`, each naming the rule it
  follows);
* **reader gap** — refused for any other reason: a file the firmware flies and the
  planner cannot read.

Run::

    python tools/missions_real.py [FOLDER] [--markdown]

The last line printed is the count of each class.
"""

from __future__ import annotations

import argparse
import re
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

FOLDER = REPO.parent / "shared" / "data" / "missions_real"
MULTIROTOR, FIXED_WING = REPO / "aircraft/solo_survey.yaml", REPO / "aircraft/x8_mapper.yaml"
#: File-name prefixes of the fixed-wing and VTOL missions among the ``.txt`` files (the
#: format carries no vehicle type).
FIXED_WING_PREFIXES = ("ap_plane", "ap_quadplane", "mavproxy_")

#: A refusal message (regular expression) and the firmware or ground-station rule that
#: refuses the same file.
FIRMWARE_REASONS = [
    (r"DO_JUMP repeat count -1 repeats for ever",
     "ArduPilot AP_Mission: a DO_JUMP repeat of -1 loops for ever "
     "(AP_MISSION_JUMP_REPEAT_FOREVER); the mission never ends"),
    (r"NAV_LOITER_UNLIM \(17\) loiters without end",
     "ArduPilot verify_loiter_unlimited returns false: the item never completes"),
    (r"not valid JSON", "QGroundControl's JSON parser refuses it (no comments in JSON)"),
    (r"version is .*QGroundControl refuses it",
     "QGroundControl JsonHelper: 'File version … is newer than current supported "
     "version 1'"),
    (r"no 'mission' key",
     "QGroundControl: 'The following required keys are missing: mission'"),
    (r"Survey items do not support version",
     "QGroundControl SurveyComplexItem: 'Survey items do not support version …'"),
    (r"StructureScan version .* not supported",
     "QGroundControl StructureScanComplexItem: '… version … not supported'"),
    (r"has no TransectStyleComplexItem\.Items",
     "QGroundControl TransectStyleComplexItem: 'The following required keys are "
     "missing: Items'"),
    (r"below the take-off point",
     "PX4 MissionFeasibilityChecker::checkHomePositionAltitude: 'Waypoint below home'"),
    (r"item 0 is .*not the home position",
     "QGroundControl and ArduPilot take row 0 as home: the file's take-off is never "
     "flown, and its absolute altitudes have no home to be read against"),
    (r"no navigation command.*nothing to fly",
     "ArduCopter ModeAuto::init: 'Auto: Missing Takeoff Cmd' (nothing to fly)"),
    (r"on another continent",
     "ArduPilot replaces the file's home with the vehicle's at upload "
     "(AP_Mission::write_home_to_storage): the route lies on another continent"),
]

READ, FIRMWARE, GAP = "read", "refused with the firmware's reason", "reader gap"


@dataclass
class Outcome:
    name: str
    vehicle: str
    status: str
    detail: str
    warnings: int = 0


def vehicle_of(path: Path) -> str:
    """The kind of aircraft a file is for: a ``.plan``'s ``vehicleType``, else its
    origin (the name's prefix)."""
    if path.suffix == ".plan":
        import json

        try:
            mission = json.loads(path.read_text(encoding="utf-8")).get("mission", {})
        except (ValueError, AttributeError):
            mission = {}
        from planner.io.mission.qgc_plan import plan_vehicle_type

        kind = plan_vehicle_type(mission) if isinstance(mission, dict) else None
        if kind is not None:
            return kind
    return "fixed_wing" if path.name.startswith(FIXED_WING_PREFIXES + ("px4_fw",)) \
        else "multirotor"


def classify(message: str) -> tuple[str, str]:
    """The class of a refusal message and the rule it matches."""
    for pattern, rule in FIRMWARE_REASONS:
        if re.search(pattern, message):
            return FIRMWARE, rule
    return GAP, ""


def read_all(folder: Path = FOLDER) -> list[Outcome]:
    """Read every ``.plan``, ``.waypoints`` and ``.txt`` file of ``folder``."""
    from planner.errors import InputError
    from planner.io.mission import NavDefaults, load_mission
    from planner.parameters import load_aircraft

    defaults = {"multirotor": NavDefaults.of(load_aircraft(MULTIROTOR)),
                "fixed_wing": NavDefaults.of(load_aircraft(FIXED_WING))}
    out = []
    for path in sorted(folder.iterdir()):
        if path.suffix.lower() not in (".plan", ".waypoints", ".txt"):
            continue
        vehicle = vehicle_of(path)
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            try:
                mission = load_mission(path, defaults=defaults[vehicle])
            except InputError as exc:
                status, rule = classify(str(exc))
                out.append(Outcome(path.name, vehicle, status,
                                   str(exc).replace(str(path) + ": ", "", 1)
                                   + (f" [{rule}]" if rule else "")))
                continue
        dist = sum(leg.distance_m for leg in mission.legs)
        out.append(Outcome(path.name, vehicle, READ,
                           f"{len(mission.legs)} legs, {dist:.0f} m flown", len(said)))
    return out


def counts(outcomes: list[Outcome]) -> dict[str, int]:
    return {c: sum(o.status == c for o in outcomes) for c in (READ, FIRMWARE, GAP)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", nargs="?", default=str(FOLDER))
    ap.add_argument("--markdown", action="store_true", help="print a Markdown table")
    args = ap.parse_args(argv)
    folder = Path(args.folder)
    if not folder.is_dir():
        print(f"{folder}: not a folder (expected the real mission files)", file=sys.stderr)
        return 2
    outcomes = read_all(folder)
    if args.markdown:
        print("| file | aircraft | outcome | detail |\n|---|---|---|---|")
        for o in outcomes:
            print(f"| `{o.name}` | {o.vehicle.replace('_', '-')} | {o.status} | "
                  f"{o.detail.replace('|', '/')} |")
    else:
        for o in outcomes:
            print(f"{o.name:55s} {o.vehicle:10s} {o.status:36s} {o.detail}")
    c = counts(outcomes)
    print(f"{len(outcomes)} files: {c[READ]} read, {c[FIRMWARE]} {FIRMWARE}, "
          f"{c[GAP]} {GAP}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""One-line figures the check prints beside its table (the flight times eCalc and other
calculators show: hover time, flight time at the best speed)."""

from __future__ import annotations

import math


def endurance_line(r) -> str | None:
    """Hover (loiter) endurance with this pack at this take-off mass, and endurance in
    level flight at the airspeed of least power, both from a full pack to the reserve
    (:meth:`planner.chain.mission_chain.ChainResult.endurance`); None when unknown."""
    e = r.endurance
    if not e or not (math.isfinite(e["hold_s"]) and math.isfinite(e["least_power_s"])):
        return None
    what = "hover" if r.aircraft_type == "multirotor" else "loiter"
    wind = r.environment.wind_speed_ms if r.environment is not None else 0.0
    where = f"in the {wind:.1f} m/s wind" if wind > 0 and what == "hover" else "still air"
    return (f"Endurance full pack to the reserve at {e['takeoff_mass_kg']:.2f} kg: {what} "
            f"{e['hold_s'] / 60:.1f} min ({e['hold_power_w']:.0f} W, {where}); level flight "
            f"at the speed of least power {e['least_power_airspeed_ms']:.1f} m/s "
            f"{e['least_power_s'] / 60:.1f} min ({e['least_power_w']:.0f} W, still air)")

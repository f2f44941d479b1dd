"""Mission files made for tests and benchmarks."""

from __future__ import annotations

from pathlib import Path

import numpy as np

def write_waypoints(path: Path, n: int = 500) -> None:
    """A lawnmower survey of ``n`` waypoints as a Mission Planner .waypoints file."""
    lat0, lon0 = 47.3977, 8.5456
    lines = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{lat0}\t{lon0}\t488\t1",
             "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t40\t1"]
    rng = np.random.default_rng(1)
    for i in range(n):
        row, col = divmod(i, 20)
        lat = lat0 + 0.0004 * row
        lon = lon0 + 0.0006 * (col if row % 2 == 0 else 19 - col)
        hold = 5 if rng.random() < 0.05 else 0
        lines.append(f"{i + 2}\t0\t3\t16\t{hold}\t0\t0\t0\t{lat:.7f}\t{lon:.7f}\t40\t1")
    lines.append(f"{n + 2}\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1")
    path.write_text("\n".join(lines) + "\n")

"""The UIUC propeller database's wind-tunnel sweeps (``../shared/data/props/uiuc``) and the
fit of :mod:`planner.physics.power.propeller`'s coefficient form to each.

Data: J. B. Brandt, R. W. Deters, G. K. Ananda, O. D. Dantsker and M. S. Selig, UIUC
Propeller Database, Vols 1–4, University of Illinois at Urbana-Champaign,
https://m-selig.ae.illinois.edu/props/propDB.html (the subset listed in the folder's
PROVENANCE.md; validation only, not copied into the repository).

Each sweep (``<family>_<D>x<P>…_<RPM>.txt``: ``J CT CP eta`` at about one rotational
speed) is fitted two ways, both by linear least squares on :math:`C_P` over its rows with
positive thrust:

* **momentum + profile** — :math:`C_P = C_T J + \\kappa C_T \\lambda_i + C_{P0}` with
  :math:`\\kappa \\ge 1`, :math:`C_{P0} \\ge 0` (:func:`planner.power.propeller.power_coefficient`);
* **constant efficiency** — :math:`C_P = C_T J / \\eta_c`, the fixed-wing model's single
  propulsive efficiency.

and scored by the RMS error of the efficiency :math:`\\eta = J C_T / C_P` it implies.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import lsq_linear

from planner.physics.power.propeller import inflow_ratio, power_coefficient

REPO = Path(__file__).resolve().parents[1]
UIUC = REPO.parent / "shared" / "data" / "props" / "uiuc"
_NAME = re.compile(r"^(?P<family>[a-z0-9]+)_(?P<size>[0-9.]+x[0-9.]+)(?:_(?P<blades>\d)b)?_"
                   r"(?P<test>[a-z0-9]+)_(?P<rpm>\d+)\.txt$")


@dataclass
class Sweep:
    name: str
    family: str
    rpm: float
    j: np.ndarray
    ct: np.ndarray
    cp: np.ndarray
    eta: np.ndarray


@dataclass
class SweepFit:
    name: str
    rows: int
    induced_factor: float
    profile_cp: float
    eta_rmse: float              # momentum + profile
    eta_rmse_constant: float     # constant efficiency
    constant_eta: float
    peak_eta: float


def sweeps(folder: Path = UIUC) -> list[Sweep]:
    """Every advance-ratio sweep under ``folder`` (none when it is absent)."""
    out = []
    for p in sorted(folder.rglob("*.txt")) if folder.is_dir() else []:
        m = _NAME.match(p.name)
        if not m or "static" in p.name or "geom" in p.name:
            continue
        rows = []
        for line in p.read_text(errors="replace").splitlines():
            parts = line.split()
            if len(parts) == 4:
                try:
                    rows.append([float(x) for x in parts])
                except ValueError:
                    continue                     # the header, "RPM average = …"
        if len(rows) < 3:
            continue
        a = np.array(rows)
        out.append(Sweep(p.stem, m["family"], float(m["rpm"]), *a.T))
    return out


def fit_sweep(s: Sweep) -> SweepFit | None:
    """Both fits of one sweep (module notes); None with fewer than 3 rows of thrust."""
    ok = (s.ct > 0) & (s.cp > 0) & (s.j > 0) & np.isfinite(s.eta)
    j, ct, cp = s.j[ok], s.ct[ok], s.cp[ok]
    if ok.sum() < 3:
        return None
    eta = j * ct / cp
    a = np.column_stack([ct * inflow_ratio(j, ct), np.ones_like(j)])
    sol = lsq_linear(a, cp - ct * j, bounds=([1.0, 0.0], [np.inf, np.inf]))
    kappa, cp0 = map(float, sol.x)
    eta_model = j * ct / power_coefficient(j, ct, kappa, cp0)
    x = ct * j                                   # C_P = x / η_c: least squares in 1/η_c
    inv = float(np.dot(x, cp) / np.dot(x, x))
    eta_const = np.full(j.shape, 1.0 / inv)
    rms = lambda e: float(np.sqrt(np.mean((e - eta) ** 2)))  # noqa: E731
    return SweepFit(s.name, int(ok.sum()), kappa, cp0, rms(eta_model), rms(eta_const),
                    1.0 / inv, float(eta.max()))

r"""Battery pack selection: every pack of a catalog on one mission, mass loop closed.

The pre-flight check (:class:`planner.check.MissionChain`) answers "does *this* pack
fly *this* mission with the reserve?". Pack selection asks it of a whole catalog at
once, and each pack changes the answer through its own mass: take-off mass =
aircraft empty mass + pack mass × ``count`` + payload, so a bigger pack also needs
more power. :func:`evaluate_packs` runs the *same* physics and reserve rules as
``check``, vectorised over packs:

* the leg kinematics (:func:`planner.profile.leg_table`) are computed once — they do
  not depend on mass;
* the battery power of every (pack, flight state) pair comes from
  :meth:`planner.definitions.Aircraft.battery_power` with the masses as a column
  (see :class:`PowerTable` for how it is kept fast with many packs);
* the integral-model stress :math:`S = \int dt/(\delta P^\varepsilon)` is summed leg
  by leg with per-pack δ, ε, β; the charge is :math:`\hat C = S^{1/\beta}`;
* the landing reserve, the return-home reserve at
  :data:`planner.profile.RTL_POINTS_PER_LEG` points per leg (the same geometry as
  ``MissionChain._return_home``), the C rating with the loaded current of
  :func:`planner.check.loaded_current` and the take-off mass limit are checked as
  ``check`` does;
* selection adds two constraints ``check`` does not have: the aircraft's allowed cell
  counts (``cells_series_allowed``) and, for multirotors with a known
  ``multirotor.max_thrust_n``, a minimum thrust-to-weight ratio;
* packs with an equivalent-circuit or thermal block, whose usable charge ``check``
  takes from a time-stepped circuit simulation, are run through
  :meth:`~planner.check.MissionChain.run` one by one (that model is not vectorised).

Because the stress is additive and the charge a monotone function of it, the
return-home test "charge(S_point + S_return) ≤ limit" is done on stresses:
:math:`S_{point} + S_{return} \le (limit/scale)^\beta`; no power-law charge is
evaluated per return point.

:func:`select_pack` ranks the packs (objective ``mass``, ``margin`` or ``price``)
and names the binding constraint of every rejected pack. Catalogs are YAML files
with a ``packs:`` list (:func:`load_catalog`) or folders of pack files.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from planner import profile as prof
from planner import schema as S
from planner.battery import integral
from planner.battery.ocv import lipo_ocv
from planner.check import loaded_current
from planner.definitions import Aircraft, BatteryPack, battery_from_mapping
from planner.errors import InputError
from planner.mission.legs import Environment, Mission
from planner.units import AS_PER_MAH

__all__ = ["CATALOG_KEYS", "CONSTRAINTS", "DEFAULT_MIN_THRUST_TO_WEIGHT", "OBJECTIVES",
           "PackEvaluation", "PowerTable", "Selection", "catalog_from_mapping",
           "evaluate_packs", "load_catalog", "rank_packs", "select_pack"]

#: Ranking objectives: lightest pack, largest landing margin (as extra hover or loiter
#: time), cheapest pack.
OBJECTIVES = ("mass", "margin", "price")

#: Minimum thrust-to-weight ratio of a multirotor (controllability margin for gusts
#: and manoeuvres) when the aircraft gives ``multirotor.max_thrust_n``. [unitless]
DEFAULT_MIN_THRUST_TO_WEIGHT = 1.5

#: Constraint codes, in the order in which the first violated one is reported as the
#: *binding* constraint of a rejected pack.
CONSTRAINTS = ("mission", "cells", "takeoff_mass", "thrust", "power", "c_rating",
               "voltage", "runs_out", "landing_reserve", "return_home")
_CHECK_CONSTRAINTS = ("mission", "takeoff_mass", "power", "c_rating", "voltage", "runs_out",
                      "landing_reserve", "return_home")

#: Top-level keys of a catalog file.
CATALOG_KEYS = {
    "packs": S.Key(S.LIST, required=True),
    "name": S.Key(S.TEXT),
    "source": S.Key(S.TEXT),
}

G = prof.G


# --------------------------------------------------------------------------- catalog

def catalog_from_mapping(data: Any, where: str) -> list[BatteryPack]:
    """Validate a catalog mapping (``packs:`` list of DESIGN §8 packs) and build the packs.

    Each pack is validated with :func:`planner.definitions.battery_from_mapping`
    under the name ``"{where}: packs[i]"``; every problem of every pack is reported
    at once in one line.

    Raises
    ------
    InputError
        A missing or empty ``packs`` list, an unknown top-level key, or any problem in
        any pack (``catalog.yaml: packs[2]: mass_kg must be > 0, got -1``).
    """
    d = S.check_mapping(data, CATALOG_KEYS, where)
    items = d["packs"]
    if not items:
        raise InputError(f"{where}: 'packs' is empty, expected a list of battery packs")
    packs, problems = [], []
    for i, item in enumerate(items):
        try:
            packs.append(battery_from_mapping(item, f"{where}: packs[{i}]"))
        except InputError as exc:
            problems.append(str(exc))
    if problems:
        raise InputError("; ".join(problems))
    return packs


def load_catalog(path: str | Path) -> list[BatteryPack]:
    """Load a pack catalog: a YAML file with a ``packs:`` list, or a folder of pack files.

    Parameters
    ----------
    path : str or Path
        A catalog file (``packs:`` list of battery mappings, DESIGN §8, each with
        optional ``price`` and ``count``), or a folder whose ``*.yaml``/``*.yml``
        files are single packs or catalogs themselves (read in name order).

    Returns
    -------
    list of BatteryPack
    """
    path = Path(path)
    if path.is_dir():
        files = sorted(p for p in path.iterdir()
                       if p.suffix.lower() in (".yaml", ".yml") and p.is_file())
        if not files:
            raise InputError(f"{path}: folder holds no pack files (*.yaml)")
        packs, problems = [], []
        for f in files:
            try:
                data = S.load_yaml(f)
                if isinstance(data, dict) and "packs" in data:
                    packs.extend(catalog_from_mapping(data, str(f)))
                else:
                    packs.append(battery_from_mapping(data, str(f)))
            except InputError as exc:
                problems.append(str(exc))
        if problems:
            raise InputError("; ".join(problems))
        return packs
    return catalog_from_mapping(S.load_yaml(path), str(path))


# --------------------------------------------------------------------------- power table

class PowerTable:
    r"""
    Battery power of one aircraft at a set of flight states, for any take-off masses.

    The flight states (airspeed, climb rate, air density, load factor) of the legs,
    of the return-home points and of the hold are de-duplicated; the power at a block
    of masses is then ``aircraft.battery_power(state..., mass[:, None])``.

    With many distinct masses (a large catalog) evaluating the model at every
    (mass, state) pair costs too much for the iterative momentum model (a few µs per
    pair). Then (``method="table"``, chosen by ``"auto"`` when the catalog has more
    than ``2 * nodes - 1`` distinct masses, i.e. when it needs fewer model calls) the
    model is evaluated exactly at ``nodes`` Chebyshev masses spanning the catalog and
    :math:`\ln P` is interpolated in :math:`\ln m` (barycentric formula, one matrix
    product for all packs). Every state is checked at the ``nodes - 1`` masses between
    the nodes against the exact model. A state that misses by more than ``tolerance``
    (relative) — a kink such as the idle-speed power floor of a fast descent — is
    interpolated piecewise instead: its mass range is halved until each piece passes
    the same check (at most ``max_depth`` halvings; a piece that still fails, and any
    state whose power is not positive and finite, is evaluated exactly).

    Parameters
    ----------
    aircraft : Aircraft
    airspeed, climb_rate, air_density, load_factor : array_like
        One element per flight state (broadcast together). [m/s], [m/s], [kg m⁻³], [–]
    masses : array_like
        All take-off masses that will be asked for. [kg]
    method : {"auto", "exact", "table"}
    nodes : int, default 16
    tolerance : float, default 1e-9
        Largest relative error accepted at the check masses. [unitless]
    max_depth : int, default 16
    """

    def __init__(self, aircraft: Aircraft, airspeed, climb_rate, air_density, load_factor,
                 masses, *, method: str = "auto", nodes: int = 16, tolerance: float = 1e-9,
                 max_depth: int = 16):
        if method not in ("auto", "exact", "table"):
            raise ValueError(f"method must be 'auto', 'exact' or 'table', got {method!r}")
        cols = np.broadcast_arrays(*(np.asarray(a, float) for a in
                                     (airspeed, climb_rate, air_density, load_factor)))
        states = np.column_stack([np.ravel(c) for c in cols])
        if np.all(np.isfinite(states)):
            self.states, self.inverse = np.unique(states, axis=0, return_inverse=True)
            self.inverse = self.inverse.ravel()
        else:  # np.unique does not merge NaN rows reliably: keep every state
            self.states, self.inverse = states, np.arange(len(states))
        self.aircraft = aircraft
        m = np.unique(np.asarray(masses, float))
        if method == "auto":
            method = "table" if m.size > 2 * nodes - 1 else "exact"
        self.method = method
        self.n_table = 0
        self.pieces: list[list[tuple]] = []
        self.model_calls = 0
        if method == "table" and m.size > 1 and m[-1] > m[0]:
            self._build_table(np.log(m[0]), np.log(m[-1]), nodes, tolerance, max_depth)
        else:
            self.method = "exact"

    # -- exact model calls
    def _exact(self, mass, columns):
        s = self.states[columns]
        self.model_calls += len(mass) * len(s)
        return np.asarray(self.aircraft.battery_power(
            s[:, 0], s[:, 1], s[:, 2], np.asarray(mass, float)[:, None],
            load_factor=s[:, 3]), dtype=float).reshape(len(mass), len(columns))

    def _fit(self, lo, hi, columns, nodes, tolerance):
        """Interpolate ln P of each column on its own interval [lo, hi] (ln mass).

        ``lo``, ``hi`` broadcast against ``columns``; one model call for the nodes and
        one for the check masses of all (column, interval) pairs. Returns the nodes,
        weights, ln P at the nodes (nodes × columns), and which columns have a positive
        finite power and which pass the check.
        """
        columns = np.asarray(columns)
        lo, hi = (np.broadcast_to(np.asarray(v, float), columns.shape) for v in (lo, hi))
        j = np.arange(nodes)[:, None]
        c, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
        x = c + h * np.cos(np.pi * j / (nodes - 1))           # Chebyshev points, 2nd kind
        w = (-1.0) ** np.arange(nodes)
        w[[0, -1]] *= 0.5
        x_check = c + h * np.cos(np.pi * (j[:-1] + 0.5) / (nodes - 1))
        st = self.states[columns]

        def call(log_mass):
            self.model_calls += log_mass.size
            return np.asarray(self.aircraft.battery_power(
                st[:, 0], st[:, 1], st[:, 2], np.exp(log_mass), load_factor=st[:, 3]),
                dtype=float) * np.ones(log_mass.shape)

        p_nodes, p_check = call(x), call(x_check)
        positive = np.all(np.isfinite(p_nodes) & (p_nodes > 0), axis=0) & np.all(
            np.isfinite(p_check) & (p_check > 0), axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            y = np.log(np.where(positive, p_nodes, 1.0))
            # barycentric interpolation at the check points, column by column
            d = x_check[:, None, :] - x[None, :, :]
            q = w[None, :, None] / d
            y_check = np.sum(q * y[None], axis=1) / np.sum(q, axis=1)
            err = np.abs(np.expm1(y_check - np.log(np.where(positive, p_check, 1.0))))
        return x, w, y, positive, positive & np.all(err <= tolerance, axis=0)

    def _build_table(self, lo, hi, nodes, tolerance, max_depth):
        all_cols = np.arange(len(self.states))
        x, w, y, positive, good = self._fit(lo, hi, all_cols, nodes, tolerance)
        # the states interpolated over the whole range first (one contiguous block)
        order = np.concatenate([np.flatnonzero(good), np.flatnonzero(~good)])
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        self.states, self.inverse = self.states[order], rank[self.inverse]
        self.n_table = int(good.sum())
        self.nodes_log_mass, self.weights = x[:, 0], w
        self.log_power_nodes = np.ascontiguousarray(y[:, order[:self.n_table]])
        # the others: halve their mass range until each piece passes (breadth first,
        # every piece of one level in one model call)
        rest = np.arange(self.n_table, len(self.states))
        pieces: dict[int, list[tuple]] = {int(c): [] for c in rest}
        pending = [(int(c), lo, hi) for c in rest if positive[order[c]]]
        for c in rest:
            if not positive[order[c]]:
                pieces[int(c)].append((lo, hi, None, None, None))
        for depth in range(max_depth + 1):
            if not pending:
                break
            cols = np.array([p[0] for p in pending])
            los = np.array([p[1] for p in pending])
            his = np.array([p[2] for p in pending])
            x, w, y, positive, good = self._fit(los, his, cols, nodes, tolerance)
            nxt = []
            for i, (c, a, b) in enumerate(pending):
                if good[i]:
                    pieces[c].append((a, b, x[:, i], w, y[:, i]))
                elif not positive[i] or depth == max_depth:
                    pieces[c].append((a, b, None, None, None))   # exact model here
                else:
                    mid = 0.5 * (a + b)
                    nxt += [(c, a, mid), (c, mid, b)]
            pending = nxt
        self.pieces = [sorted(pieces[int(c)], key=lambda p: p[0]) for c in rest]

    def power(self, mass) -> np.ndarray:
        """Battery power at every de-duplicated state, shape (len(mass), n_states). [W]"""
        return np.exp(self.log_power(mass))

    def log_power(self, mass) -> np.ndarray:
        """:math:`\\ln P` at every state, shape (len(mass), n_states); −inf where P ≤ 0."""
        mass = np.asarray(mass, float).ravel()
        if self.method == "exact":
            return _log(self._exact(mass, np.arange(len(self.states))))
        out = np.empty((mass.size, len(self.states)))
        lnm = np.log(mass)
        basis = _barycentric(lnm, self.nodes_log_mass, self.weights)
        np.matmul(basis, self.log_power_nodes, out=out[:, :self.n_table])
        for c, pieces in enumerate(self.pieces, start=self.n_table):
            edges = np.array([p[1] for p in pieces[:-1]])
            which = np.searchsorted(edges, lnm)
            for q in np.unique(which):
                rows = np.flatnonzero(which == q)
                _, _, x, w, y = pieces[q]
                if x is None:
                    out[rows, c] = _log(self._exact(mass[rows], [c]))[:, 0]
                else:
                    out[rows, c] = _barycentric(lnm[rows], x, w) @ y
        return out


def _log(p):
    """ln P with −inf where P ≤ 0 (a rest) and NaN kept."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(p > 0, np.log(np.where(p > 0, p, 1.0)), np.where(np.isnan(p), np.nan,
                                                                         -np.inf))


def _barycentric(x, nodes, weights):
    """Lagrange basis at ``x`` for the given nodes (barycentric formula), shape (x, nodes)."""
    x = np.asarray(x, float).ravel()
    d = x[:, None] - nodes[None, :]
    hit = d == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        q = weights / d
        basis = q / q.sum(axis=1, keepdims=True)
    rows = hit.any(axis=1)
    if rows.any():
        basis[rows] = hit[rows].astype(float)
    return basis


# --------------------------------------------------------------------------- fast kernels

def _stress_rate(power_w, delta, epsilon):
    """:func:`planner.battery.integral.stress_rate` with exp/log instead of a power.

    Same value (to rounding) and the same conventions: 0 where the load is off
    (P ≤ 0), NaN where P is NaN; about ten times faster on large arrays.
    """
    p = np.asarray(power_w, float)
    on = p > 0
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        rate = np.exp(-epsilon * np.log(np.where(on, p, 1.0))) / delta
    rate = np.where(on, rate, 0.0)
    return np.where(np.isnan(p), np.nan, rate)


def _stress_rate_log(log_power, delta, epsilon):
    """:func:`_stress_rate` from :math:`\\ln P` (−inf: load off → 0; NaN kept)."""
    lp = np.asarray(log_power, float)
    with np.errstate(over="ignore", invalid="ignore"):
        rate = np.multiply(-epsilon, lp)
        np.exp(rate, out=rate)
        rate /= delta
    off = ~np.isfinite(lp)
    if off.any():
        rate[off] = np.where(np.isnan(lp[off]), np.nan, 0.0)
    return rate


def _charge(stress, beta):
    """:func:`planner.battery.integral.charge_from_stress` with exp/log. [A s]"""
    s = np.asarray(stress, float)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        c = np.exp(np.log(np.where(s > 0, s, 1.0)) / beta)
    return np.where(s > 0, c, np.where(np.isnan(s), np.nan, 0.0))


def _loaded_current(power_w, open_circuit_v, resistance_ohm):
    """:func:`planner.check.loaded_current` with one resistance per pack (rows).

    ``loaded_current(P, V, R)`` equals ``loaded_current(R P, V, 1 Ω) / R`` for R > 0,
    so the library function is called once for all packs. [A]
    """
    r = np.asarray(resistance_ohm, float)
    r_safe = np.where(r > 0, r, 1.0)
    p = np.asarray(power_w, float)
    current = loaded_current(r_safe * p, open_circuit_v, 1.0) / r_safe
    return np.where(r > 0, current, p / open_circuit_v)


# --------------------------------------------------------------------------- evaluation

@dataclass
class PackEvaluation:
    """Every pack of a catalog on one mission (arrays: one element per pack).

    Attributes
    ----------
    packs : list of BatteryPack
    aircraft_name, mission_name : str
    aircraft_type : str
    reserve_fraction : float
    payload_kg : float
    duration_s : float
        Mission duration (does not depend on the pack). [s]
    pack_mass_kg, takeoff_mass_kg : ndarray
        Pack mass × count; aircraft + packs + payload. [kg]
    capacity_mah, usable_mah, reserve_mah : ndarray
        Nominal (× count), usable and reserve charge. [mAh]
    charge_used_mah, margin_mah : ndarray
        Charge drawn by the integral model; usable − reserve − used. [mAh]
    remaining_fraction : ndarray
        Charge left on landing over nominal. [unitless]
    margin_time_s, hold_power_w : ndarray
        The margin as extra hover (multirotor) or loiter (fixed-wing) time at the
        hold power, as in ``check``; −inf when the reserve exceeds the usable charge.
        [s], [W]
    energy_wh : ndarray
        ∫P dt. [Wh]
    rtl_min_margin_mah : ndarray
        Smallest return-home margin along the mission. [mAh]
    pnr_index : ndarray of int
        Return-home point of the point of no return (−1: none).
    peak_current_a, max_current_a : ndarray
        Highest loaded leg current; C-rating limit (NaN: no rating). [A]
    thrust_to_weight : ndarray
        Maximum static thrust over take-off weight (NaN: not known). [unitless]
    violated : ndarray of bool, shape (k, len(CONSTRAINTS))
        Which constraints each pack violates (columns in :data:`CONSTRAINTS` order).
        ``voltage``: the equivalent-circuit model of a pack that has one (loaded
        voltage at the cut-off during the mission, voltage collapse, pack temperature
        out of range, or a cut-off that leaves the mission short of the reserve).
    notes : list of str
        What the user should know about the evaluation as a whole.
    """

    packs: list[BatteryPack]
    aircraft_name: str
    aircraft_type: str
    mission_name: str
    reserve_fraction: float
    payload_kg: float
    min_thrust_to_weight: float
    duration_s: float
    pack_mass_kg: np.ndarray
    takeoff_mass_kg: np.ndarray
    capacity_mah: np.ndarray
    usable_mah: np.ndarray
    reserve_mah: np.ndarray
    charge_used_mah: np.ndarray
    margin_mah: np.ndarray
    remaining_fraction: np.ndarray
    margin_time_s: np.ndarray
    hold_power_w: np.ndarray
    energy_wh: np.ndarray
    rtl_min_margin_mah: np.ndarray
    pnr_index: np.ndarray
    peak_current_a: np.ndarray
    peak_leg: np.ndarray
    undeliverable_leg: np.ndarray
    max_current_a: np.ndarray
    thrust_to_weight: np.ndarray
    violated: np.ndarray
    max_takeoff_mass_kg: float | None = None
    cells_allowed: tuple[int, ...] | None = None
    mission_problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    leg_origin: list[str] = field(default_factory=list, repr=False)
    rtl_points: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    method: str = "exact"
    #: Packs evaluated by :meth:`planner.check.MissionChain.run` itself (those with an
    #: equivalent-circuit or thermal block): index -> that result.
    checked: dict[int, Any] = field(default_factory=dict, repr=False)

    def __len__(self) -> int:
        return len(self.packs)

    @property
    def feasible(self) -> np.ndarray:
        """Packs that satisfy every constraint. [bool]"""
        return ~self.violated.any(axis=1)

    @property
    def check_go(self) -> np.ndarray:
        """The verdict ``check`` would give each pack (its own constraints only). [bool]"""
        cols = [CONSTRAINTS.index(c) for c in _CHECK_CONSTRAINTS]
        return ~self.violated[:, cols].any(axis=1)

    def constraints(self, i: int) -> list[str]:
        """Codes of the constraints pack ``i`` violates, binding first."""
        return [c for c, v in zip(CONSTRAINTS, self.violated[i]) if v]

    def binding(self, i: int) -> str | None:
        """The binding (first violated) constraint of pack ``i``; None when feasible."""
        codes = self.constraints(i)
        return codes[0] if codes else None

    def point_of_no_return(self, i: int) -> dict | None:
        """Where pack ``i`` can no longer return home with the reserve (as in ``check``)."""
        if i in self.checked:
            return self.checked[i].point_of_no_return
        j = int(self.pnr_index[i])
        if j < 0:
            return None
        r = self.rtl_points
        leg = int(r["leg"][j])
        return {"time_s": float(r["time_s"][j]), "leg": leg + 1,
                "leg_origin": self.leg_origin[leg] or f"leg {leg + 1}",
                "east_m": float(r["east_m"][j]), "north_m": float(r["north_m"][j]),
                "altitude_m": float(r["altitude_m"][j]),
                "distance_home_m": float(r["distance_m"][j])}

    def reasons(self, i: int) -> list[str]:
        """Why pack ``i`` is rejected, one message per violated constraint."""
        p = self.packs[i]
        out: list[str] = []
        for code in self.constraints(i):
            if i in self.checked and code in _CHECK_CONSTRAINTS:
                if not any(m in out for m in self.checked[i].reasons):
                    out.extend(self.checked[i].reasons)   # check's own words
            elif code == "mission":
                out.extend(self.mission_problems)
            elif code == "cells":
                out.append(f"{p.cells_series}S pack, the aircraft allows "
                           + ", ".join(f"{c}S" for c in self.cells_allowed))
            elif code == "takeoff_mass":
                out.append(f"take-off mass {self.takeoff_mass_kg[i]:.2f} kg exceeds the "
                           f"aircraft's maximum {self.max_takeoff_mass_kg:.2f} kg")
            elif code == "thrust":
                out.append(f"thrust-to-weight {self.thrust_to_weight[i]:.2f} is below the "
                           f"minimum {self.min_thrust_to_weight:g}")
            elif code == "power":
                leg = int(self.undeliverable_leg[i])
                out.append(f"{self.leg_origin[leg] or f'leg {leg + 1}'}: the pack cannot "
                           f"deliver the power through its internal resistance")
            elif code == "c_rating":
                leg = int(self.peak_leg[i])
                out.append(f"{self.leg_origin[leg] or f'leg {leg + 1}'}: current "
                           f"{self.peak_current_a[i]:.1f} A exceeds the pack's "
                           f"{p.max_discharge_c:g} C rating ({self.max_current_a[i]:.1f} A)")
            elif code == "runs_out":
                out.append(f"needs {self.charge_used_mah[i]:.0f} mAh, more than the "
                           f"{self.usable_mah[i]:.0f} mAh the pack can give: it runs out "
                           "before landing")
            elif code == "landing_reserve":
                out.append(f"lands with {100 * self.remaining_fraction[i]:.1f} % of nominal "
                           f"charge, below the {100 * self.reserve_fraction:.0f} % reserve "
                           f"(short by {-self.margin_mah[i]:.0f} mAh)")
            elif code == "return_home":
                pnr = self.point_of_no_return(i)
                out.append(f"cannot return home with the reserve from t = "
                           f"{pnr['time_s']:.0f} s ({pnr['leg_origin']}, "
                           f"{pnr['distance_home_m']:.0f} m from home): point of no return "
                           "passed")
        return out

    def pack_dict(self, i: int) -> dict[str, Any]:
        """JSON-ready summary of pack ``i`` (units in the key names)."""
        p = self.packs[i]
        pnr = self.point_of_no_return(i)
        return {
            "name": p.name + (f" x{p.count}" if p.count > 1 else ""),
            "feasible": bool(self.feasible[i]),
            "mass_kg": _num(self.pack_mass_kg[i]),
            "margin_mah": _num(self.margin_mah[i]),
            "reasons": self.reasons(i),
            "binding": self.binding(i),
            "constraints": self.constraints(i),
            "check_verdict": "GO" if self.check_go[i] else "NO-GO",
            "count": p.count, "cells_series": p.cells_series,
            "chemistry": p.chemistry,
            "capacity_mah": _num(self.capacity_mah[i]),
            "takeoff_mass_kg": _num(self.takeoff_mass_kg[i]),
            "charge_used_mah": _num(self.charge_used_mah[i]),
            "remaining_fraction": _num(self.remaining_fraction[i]),
            "margin_time_s": _num(self.margin_time_s[i]),
            "rtl_min_margin_mah": _num(self.rtl_min_margin_mah[i]),
            "point_of_no_return": pnr,
            "energy_wh": _num(self.energy_wh[i]),
            "peak_current_a": _num(self.peak_current_a[i]),
            "max_current_a": _num(self.max_current_a[i]),
            "thrust_to_weight": _num(self.thrust_to_weight[i]),
            "price": None if p.price is None else float(p.price),
            "battery_model": "literature" if p.model.literature else "from the pack file",
            "model_source": None if p.model.literature else p.model.source,
            "source": p.source,
        }

    def to_frame(self) -> pd.DataFrame:
        """One row per pack, catalog order."""
        return pd.DataFrame({
            "name": [p.name + (f" x{p.count}" if p.count > 1 else "") for p in self.packs],
            "cells_series": [p.cells_series for p in self.packs],
            "capacity_mah": self.capacity_mah, "pack_mass_kg": self.pack_mass_kg,
            "takeoff_mass_kg": self.takeoff_mass_kg, "charge_used_mah": self.charge_used_mah,
            "margin_mah": self.margin_mah, "margin_time_s": self.margin_time_s,
            "rtl_min_margin_mah": self.rtl_min_margin_mah,
            "peak_current_a": self.peak_current_a, "max_current_a": self.max_current_a,
            "thrust_to_weight": self.thrust_to_weight, "feasible": self.feasible,
            "binding": [self.binding(i) for i in range(len(self))],
        })


def _num(v):
    v = float(v)
    return round(v, 6) if np.isfinite(v) else None


def _pack_arrays(packs, temperature_c):
    """Per-pack parameters as arrays (one Python pass over the catalog).

    The totals are those of :class:`~planner.definitions.BatteryPack` (``count``
    packs in parallel: mass and capacity × count, resistance ÷ count).
    """
    nan = float("nan")
    rows = [(p.mass_kg, p.count, p.capacity_mah, p.usable_fraction,
             nan if p.internal_resistance_ohm is None else p.internal_resistance_ohm,
             nan if p.max_discharge_c is None else p.max_discharge_c, p.cells_series,
             p.model.delta, p.model.epsilon, p.model.beta,
             p.model.charge_scale(temperature_c)
             if (p.model.fade_per_cycle or p.model.temperature_coefficient_per_c) else 1.0)
            for p in packs]
    (m, count, cap_mah, frac, r, c_rate, cells, delta, eps, beta,
     scale) = np.array(rows, dtype=float).T
    total_mah = cap_mah * count
    return {"mass": m * count, "cap": total_mah * AS_PER_MAH, "usable": total_mah * AS_PER_MAH * frac,
            "r": np.nan_to_num(r, nan=0.0) / count, "imax": c_rate * total_mah / 1000.0,
            "cells": cells, "delta": delta, "eps": eps, "beta": beta, "scale": scale}


def evaluate_packs(mission: Mission, aircraft: Aircraft, packs: list[BatteryPack],
                   environment: Environment | None = None, *, reserve: float = 0.2,
                   temperature_c: float | None = None, payload_kg: float | None = None,
                   min_thrust_to_weight: float = DEFAULT_MIN_THRUST_TO_WEIGHT,
                   method: str = "auto", block_elements: int = 2_000_000) -> PackEvaluation:
    """Fly ``mission`` with every pack of a catalog: power, charge, reserves, constraints.

    The same physics and reserve rules as :meth:`planner.check.MissionChain.run`, with
    the mass loop closed per pack and every step vectorised over packs.

    Parameters
    ----------
    mission : Mission
    aircraft : Aircraft
    packs : list of BatteryPack
    environment : Environment, optional
        Overrides the mission's weather (``--wind``).
    reserve : float, default 0.2
        Landing reserve as a fraction of nominal capacity. [unitless]
    temperature_c : float, optional
        Outside air temperature; None = the mission's, else ISA. [°C]
    payload_kg : float, optional
        Overrides the mission's payload. [kg]
    min_thrust_to_weight : float, default 1.5
        Multirotors with ``multirotor.max_thrust_n``: least maximum thrust over
        take-off weight. [unitless]
    method : {"auto", "exact", "table"}
        How the power is evaluated over many masses, see :class:`PowerTable`.
    block_elements : int
        Packs are processed in blocks of about this many (pack × point) elements,
        which bounds the memory.

    Returns
    -------
    PackEvaluation
    """
    if not 0.0 <= reserve < 1.0:
        raise InputError(f"--reserve must be in [0, 1), got {reserve}")
    if not packs:
        raise InputError("the pack catalog is empty")
    if not mission.legs:
        raise InputError(f"{mission.source or mission.name}: the mission has no legs")
    invalid = [f"{p.path or p.name}: integral model delta = {p.model.delta:.4g}"
               + (f" (literature δ₀({p.cells_series}) is only valid for few-cell packs; give "
                  "a fitted 'model:')" if p.model.literature else "")
               for p in packs if not (p.model.delta > 0 and p.model.beta > 0)]
    if invalid:
        raise InputError("; ".join(invalid) + " — delta must be > 0")
    env = environment or mission.environment
    ac = aircraft
    temp = temperature_c if temperature_c is not None else env.temperature_c
    payload = mission.payload_kg if payload_kg is None else float(payload_kg)
    table = prof.leg_table(mission, ac, env, temperature_c=temp)
    n = len(table)
    k = len(packs)
    pa = _pack_arrays(packs, temp)
    mass = ac.empty_mass_kg + pa["mass"] + payload
    cap, usable, scale = pa["cap"], pa["usable"], pa["scale"]
    limit = usable - reserve * cap

    # flight states: legs, return-home (back, down), hold; one power table for all
    rtl = prof.return_home_points(table, ac, env, temp)
    npts = len(rtl["leg"])
    rho0 = float(table.air_density[-1])
    if ac.is_multirotor:
        hold = (float(env.wind_speed_ms), 0.0, rho0, 1.0)
    else:
        fw = ac.fixed_wing
        v = fw.loiter_airspeed_ms or fw.cruise_airspeed_ms
        hold = (v, 0.0, rho0, float(np.sqrt(1.0 + (v**2 / (G * fw.loiter_radius_m)) ** 2)))
    groups = [(table.airspeed_ms, table.climb_rate_ms, table.air_density, table.load_factor),
              rtl["back"], rtl["down"], hold]
    sizes = [n, npts, npts, 1]
    cols = [np.concatenate([np.broadcast_to(np.asarray(g[c], float), (s,))
                            for g, s in zip(groups, sizes)]) for c in range(4)]
    ptable = PowerTable(ac, *cols, masses=mass, method=method)
    inv = ptable.inverse
    i_leg, i_back = inv[:n], inv[n:n + npts]
    i_down, i_hold = inv[n + npts:n + 2 * npts], inv[-1]

    dur = table.duration_s
    t_back, t_down = rtl["t_back"], rtl["t_down"]
    f_points = np.linspace(0.0, 1.0, prof.RTL_POINTS_PER_LEG)

    out = {name: np.empty(k) for name in (
        "used", "energy", "peak", "rtl_min", "s_final", "p_hold")}
    pnr_index = np.full(k, -1, dtype=int)
    peak_leg = np.zeros(k, dtype=int)
    undeliverable = np.full(k, -1, dtype=int)
    block = max(1, int(block_elements // max(npts, len(ptable.states), 1)))
    for b0 in range(0, k, block):
        sl = slice(b0, min(k, b0 + block))
        delta, eps, beta = (pa[x][sl, None] for x in ("delta", "eps", "beta"))
        sc, cp, rr, cells = (pa[x][sl, None] for x in ("scale", "cap", "r", "cells"))
        lp_u = ptable.log_power(mass[sl])
        r_u = _stress_rate_log(lp_u, delta, eps)
        power = np.exp(lp_u[:, i_leg])
        inc = dur * r_u[:, i_leg]
        s_end = np.cumsum(inc, axis=1)
        s_start = s_end - inc
        c_end = sc * _charge(s_end, beta)
        c_start = np.concatenate([np.zeros((c_end.shape[0], 1)), c_end[:, :-1]], axis=1)
        out["used"][sl] = c_end[:, -1]
        out["s_final"][sl] = s_end[:, -1]
        out["energy"][sl] = power @ dur / 3600.0
        out["p_hold"][sl] = np.exp(lp_u[:, i_hold])

        # loaded current and voltage (open-circuit curve + pack resistance)
        soc_mid = 1.0 - 0.5 * (c_start + c_end) / cp
        current = _loaded_current(power, cells * lipo_ocv(soc_mid), rr)
        finite = np.isfinite(current)
        cur = np.where(finite, current, -np.inf)
        peak_leg[sl] = np.argmax(cur, axis=1)
        peak = cur.max(axis=1)
        out["peak"][sl] = np.where(np.isfinite(peak), peak, np.nan)
        bad_i = ~finite & np.isfinite(power)
        undeliverable[sl] = np.where(bad_i.any(axis=1), np.argmax(bad_i, axis=1), -1)

        # return-home reserve, on stresses: S_point + S_return <= (limit/scale)^beta
        total = r_u[:, i_back]
        total *= t_back
        down = r_u[:, i_down]
        down *= t_down
        total += down
        total += (s_start[:, :, None] + inc[:, :, None] * f_points).reshape(total.shape)
        total[:, -1] = s_end[:, -1]   # the mission's own end: the landing reserve
        total[np.isnan(total)] = np.inf
        lim = limit[sl]
        s_lim = np.where(lim >= 0, integral.stress_from_charge(
            np.maximum(lim, 0.0) / pa["scale"][sl], pa["beta"][sl]), -np.inf)
        bad = total[:, :-1] > s_lim[:, None]
        pnr_index[sl] = np.where(bad.any(axis=1), np.argmax(bad, axis=1), -1)
        t_max = total.max(axis=1)
        rows = np.flatnonzero(~np.isfinite(t_max))
        if rows.size:  # largest finite total where some return is impossible
            t_max[rows] = np.where(np.isfinite(total[rows]), total[rows], -np.inf).max(axis=1)
        with np.errstate(invalid="ignore"):
            rtl_min = lim - pa["scale"][sl] * _charge(t_max, pa["beta"][sl])
        out["rtl_min"][sl] = np.where(np.isfinite(t_max), rtl_min, -np.inf)

    used = out["used"]
    usable = usable.copy()
    margin = limit - used
    with np.errstate(invalid="ignore", divide="ignore"):
        margin_time = integral.time_to_charge(out["s_final"], out["p_hold"],
                                              np.maximum(limit, 0.0) / scale, pa["delta"],
                                              pa["eps"], pa["beta"])
    margin_time = np.where(limit <= 0, -np.inf, margin_time)

    # packs with an equivalent-circuit or thermal block: the time-stepped circuit model
    # of ``check`` limits their usable charge; run ``check`` itself for them
    checked = {}
    circuit_packs = [i for i, p in enumerate(packs)
                     if p.circuit is not None or p.thermal is not None]
    if circuit_packs:
        from planner.check import MissionChain
        flown = mission if payload_kg is None else replace(mission, payload_kg=payload)
        for i in circuit_packs:
            r = MissionChain(ac, packs[i], reserve=reserve, temperature_c=temperature_c).run(
                flown, env)
            checked[i] = r
            used[i], margin[i] = r.charge_used_mah * AS_PER_MAH, r.margin_mah * AS_PER_MAH
            margin_time[i] = r.margin_time_s
            usable[i] = r.usable_mah * AS_PER_MAH
            out["rtl_min"][i] = r.rtl_min_margin_mah * AS_PER_MAH
            pnr_index[i] = -1 if r.point_of_no_return is None else 0
    usable_now = usable.copy()

    # constraints
    violated = np.zeros((k, len(CONSTRAINTS)), dtype=bool)

    def mark(code, mask):
        violated[:, CONSTRAINTS.index(code)] = mask

    mission_problems = [f"{table.origin[i] or f'leg {i + 1}'}: {why}"
                        for i, why in table.problems]
    mark("mission", np.full(k, bool(mission_problems)))
    notes: list[str] = list(table.notes)
    allowed = ac.cells_series_allowed
    if allowed:
        mark("cells", ~np.isin(pa["cells"], allowed))
    mtow = ac.max_takeoff_mass_kg
    if mtow is not None:
        mark("takeoff_mass", mass > mtow)
    tw = np.full(k, np.nan)
    if ac.is_multirotor:
        thrust = ac.multirotor.max_thrust_n
        if thrust is not None:
            tw = thrust / (mass * G)
            mark("thrust", tw < min_thrust_to_weight)
        else:
            notes.append("thrust-to-weight not checked: the aircraft file gives no "
                         "multirotor.max_thrust_n")
    mark("power", undeliverable >= 0)
    imax = pa["imax"]
    with np.errstate(invalid="ignore"):
        mark("c_rating", np.isfinite(imax) & np.isfinite(out["peak"]) & (out["peak"] > imax))
    voltage = np.zeros(k, bool)
    for i, r in checked.items():
        full = packs[i].usable_as
        voltage[i] = bool(r.circuit and r.circuit.get("reasons")) or (
            usable_now[i] < full and margin[i] < 0)
    mark("voltage", voltage)
    runs_out = ~voltage & (used > usable_now)
    mark("runs_out", runs_out)
    mark("landing_reserve", ~voltage & ~runs_out & (margin < 0))
    mark("return_home", pnr_index >= 0)
    no_rating = int(np.sum(~np.isfinite(imax)))
    if no_rating:
        notes.append(f"C rating not checked for {no_rating} pack(s) without "
                     "max_discharge_c")
    if checked:
        notes.append(f"{len(checked)} pack(s) with an equivalent-circuit or thermal block were "
                     "evaluated one by one with the pre-flight check's time-stepped circuit "
                     "model")
    literature = sorted({p.cells_series for p in packs if p.model.literature})
    n_lit = sum(p.model.literature for p in packs)
    if n_lit:
        notes.append(f"battery model: {n_lit} of {k} pack(s) have no fitted δ, ε and use "
                     f"the literature start values δ₀(N), ε₀(N), β = "
                     f"{integral.LITERATURE_BETA} for N = "
                     + ", ".join(f"{c}S" for c in literature))

    return PackEvaluation(
        packs=list(packs), aircraft_name=ac.name, aircraft_type=ac.type,
        mission_name=mission.name, reserve_fraction=float(reserve), payload_kg=payload,
        min_thrust_to_weight=float(min_thrust_to_weight),
        duration_s=float(np.sum(dur)), pack_mass_kg=pa["mass"], takeoff_mass_kg=mass,
        capacity_mah=cap / AS_PER_MAH, usable_mah=usable / AS_PER_MAH, reserve_mah=reserve * cap / AS_PER_MAH,
        charge_used_mah=used / AS_PER_MAH, margin_mah=margin / AS_PER_MAH,
        remaining_fraction=1.0 - used / cap, margin_time_s=margin_time,
        hold_power_w=out["p_hold"], energy_wh=out["energy"],
        rtl_min_margin_mah=out["rtl_min"] / AS_PER_MAH, pnr_index=pnr_index,
        peak_current_a=out["peak"], peak_leg=peak_leg, undeliverable_leg=undeliverable,
        max_current_a=imax, thrust_to_weight=tw,
        violated=violated, max_takeoff_mass_kg=mtow, cells_allowed=allowed, checked=checked,
        mission_problems=mission_problems, notes=notes, leg_origin=list(table.origin),
        rtl_points={key: rtl[key] for key in ("leg", "time_s", "east_m", "north_m",
                                              "altitude_m", "distance_m")},
        method=ptable.method)


# --------------------------------------------------------------------------- ranking

def rank_packs(evaluation: PackEvaluation, objective: str = "mass") -> np.ndarray:
    """Pack indices in ranked order: feasible packs first, each group by the objective.

    ``mass``: lightest pack (× count) first, ties by larger margin; ``margin``: largest
    landing margin expressed as extra hover/loiter time first (charge margins in mAh
    are not comparable between cell counts), ties by lighter pack; ``price``: cheapest
    first (packs without a price last), ties by lighter pack. Rejected packs follow in
    the same order.
    """
    if objective not in OBJECTIVES:
        raise InputError(f"--objective must be one of {', '.join(OBJECTIVES)}, "
                         f"got {objective!r}")
    e = evaluation
    mt = np.where(np.isfinite(e.margin_time_s), e.margin_time_s,
                  np.where(e.margin_time_s > 0, 1e300, -1e300))
    mass = e.pack_mass_kg
    if objective == "mass":
        keys = (-mt, mass)
    elif objective == "margin":
        keys = (mass, -mt)
    else:
        price = np.array([np.inf if p.price is None else p.price for p in e.packs])
        keys = (mass, price)
    return np.lexsort(keys + (~e.feasible,))


@dataclass
class Selection:
    """A ranked catalog.

    Attributes
    ----------
    evaluation : PackEvaluation
    objective : str
    order : ndarray of int
        Pack indices, best first.
    """

    evaluation: PackEvaluation
    objective: str
    order: np.ndarray

    @property
    def best(self) -> int | None:
        """Index of the chosen pack; None when no pack is feasible."""
        if len(self.order) and self.evaluation.feasible[self.order[0]]:
            return int(self.order[0])
        return None

    @property
    def best_pack(self) -> BatteryPack | None:
        return None if self.best is None else self.evaluation.packs[self.best]

    def to_dict(self, top: int | None = None) -> dict[str, Any]:
        """JSON-ready: ``packs`` in ranked order (each with ``rank``)."""
        e = self.evaluation
        order = self.order if top is None else self.order[:top]
        packs = []
        for r, i in enumerate(order, 1):
            d = {"rank": r}
            d.update(e.pack_dict(int(i)))
            packs.append(d)
        return {"aircraft": e.aircraft_name, "mission": e.mission_name,
                "objective": self.objective, "reserve_fraction": e.reserve_fraction,
                "payload_kg": e.payload_kg, "duration_s": _num(e.duration_s),
                "feasible_count": int(e.feasible.sum()), "pack_count": len(e),
                "best": None if self.best is None else packs[0]["name"],
                "notes": list(e.notes), "packs": packs}


def select_pack(mission: Mission, aircraft: Aircraft, packs: list[BatteryPack],
                environment: Environment | None = None, *, objective: str = "mass",
                **kwargs) -> Selection:
    """Evaluate a catalog on a mission and rank it (see :func:`evaluate_packs`)."""
    if objective not in OBJECTIVES:
        raise InputError(f"--objective must be one of {', '.join(OBJECTIVES)}, "
                         f"got {objective!r}")
    evaluation = evaluate_packs(mission, aircraft, packs, environment, **kwargs)
    return Selection(evaluation, objective, rank_packs(evaluation, objective))


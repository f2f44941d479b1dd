r"""The ``circuit:``, ``thermal:`` and ``supercap:`` blocks of definition files.

Each block is validated once, when its file is loaded, and becomes a typed object: the
``thermal:`` block a :class:`~planner.physics.battery.thermal.ThermalParameters`, the
``supercap:`` block a :class:`~planner.physics.battery.supercap.SupercapParameters`, and the
``circuit:`` block a :class:`CircuitBlock` — the block as written (per cell, with the OCV
table read once), which :meth:`CircuitBlock.parameters` completes from the pack (capacity,
R0 and layout where the block leaves them out) into the
:class:`~planner.physics.battery.circuit.CircuitParameters` the physics runs on.

The tables below declare each key once: its type, unit, bound (from
:mod:`planner.physics.limits`), meaning, and the default of the physics object it builds
(the object's own default, so that a file and a program get the same model). They
validate the file and print the tables of ``docs/formats.md``. The R0 table form
(``{soc: [...], ohm: [...]}``) and the OCV table file are parsed here too.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from planner.errors import InputError
from planner.io import schema as S
from planner.parameters.ocv import read_ocv_csv
from planner.physics.battery.circuit import CircuitParameters, r0_table
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.battery.supercap import SupercapParameters
from planner.physics.battery.thermal import T_RANGE_C, ThermalParameters
from planner.physics import limits as L

__all__ = ["CIRCUIT_KEYS", "SUPERCAP_KEYS", "THERMAL_KEYS", "CircuitBlock", "circuit_block",
           "circuit_from_mapping", "circuit_to_mapping", "parse_r0", "supercap_from_mapping",
           "supercap_to_mapping", "thermal_from_mapping", "thermal_to_mapping"]

# --------------------------------------------------------------------------- circuit

_CIRCUIT = S.field_defaults(CircuitParameters)

#: Keys of a ``circuit:`` block, per cell; the pack gives what the block leaves out.
CIRCUIT_KEYS = {
    "capacity_ah": S.positive(high=L.CELL_CAPACITY_MAX_AH, unit="A h", meaning=(
        "cell capacity at T_ref (absent: the pack's `capacity_mah` / `cells_parallel`)")),
    "r0_ohm": S.Key(S.ANY, unit="Ω", meaning=(
        "ohmic resistance per cell at T_ref: a number, or `{soc: [...], ohm: [...]}` "
        "interpolated in the state of charge (absent: the pack's "
        "`internal_resistance_ohm` × parallel / series)")),
    "r1_ohm": S.non_negative(default=_CIRCUIT["r1_ohm"], high=L.CELL_RESISTANCE_MAX_OHM,
                             unit="Ω", meaning="RC-branch resistance R1 (0: no RC branch)"),
    "c1_f": S.positive(unit="F", meaning="RC-branch capacitance C1 (required if r1_ohm > 0)"),
    "hysteresis_v": S.non_negative(default=_CIRCUIT["hysteresis_v"], high=L.HYSTERESIS_MAX_V,
                                   unit="V", meaning="maximum hysteresis voltage M"),
    "hysteresis_gamma": S.non_negative(high=L.HYSTERESIS_GAMMA_MAX, meaning=(
        "hysteresis rate γ: settled within about 3 Q/γ of charge (required if "
        "hysteresis_v > 0)")),
    "ocv_csv": S.text("OCV table, a CSV `soc [1], ocv [V]` relative to the pack file "
                      "(absent: the LiPo curve of Chen and Rincón-Mora 2006)"),
    "r0_activation_energy_j_mol": S.between(
        0.0, L.ACTIVATION_ENERGY_MAX_J_MOL, default=_CIRCUIT["r0_activation_energy_j_mol"],
        unit="J/mol", meaning="Arrhenius activation energy of R0"),
    "capacity_temp_coeff_per_c": S.between(
        0.0, L.CAPACITY_TEMP_COEFF_MAX_PER_C, default=_CIRCUIT["capacity_temp_coeff_per_c"],
        unit="1/°C", meaning="capacity loss per °C below T_ref"),
    "reference_temperature_c": S.between(
        T_RANGE_C[0], T_RANGE_C[1], default=_CIRCUIT["reference_temperature_c"], unit="°C",
        meaning="T_ref, the temperature of `capacity_ah` and `r0_ohm`"),
    "coulombic_efficiency": S.share(0.0, 1.0, default=_CIRCUIT["coulombic_efficiency"],
                                    low_open=True,
                                    meaning="share of the charging charge that is stored"),
    "cells_series": S.count(L.CELLS_SERIES_MAX, meaning="cells in series (absent: the pack's)"),
    "cells_parallel": S.count(L.CELLS_PARALLEL_MAX,
                              meaning="cells in parallel (absent: the pack's)"),
    "source": S.text("where the numbers come from"),
}

#: A block with no key given: the defaults of the table, the LiPo OCV curve.
_BLANK = {**S.defaults(CIRCUIT_KEYS), "hysteresis_gamma": _CIRCUIT["hysteresis_gamma"],
          "ocv": lipo_ocv}


@dataclass(frozen=True, eq=False)
class CircuitBlock:
    """A pack file's ``circuit:`` block, validated, with its OCV table read.

    ``values`` holds every field of
    :class:`~planner.physics.battery.circuit.CircuitParameters` (the keys of
    :data:`CIRCUIT_KEYS` and ``ocv``, the OCV curve), per cell, read as attributes
    (``block.r1_ohm``): the block's values, the table's defaults where it gives none, and
    ``None`` where it leaves the value to the pack (``capacity_ah``, ``r0_ohm``,
    ``cells_series``, ``cells_parallel``). ``CircuitBlock()`` is a block with no key.
    """

    values: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType(dict(_BLANK)))

    def __getattr__(self, name: str) -> Any:
        values = self.__dict__.get("values")
        if values is None or name not in values:
            raise AttributeError(name)
        return values[name]

    def parameters(self, *, capacity_ah: float | None, r0_ohm: Any, cells_series: int,
                   cells_parallel: int, where: str = "battery") -> CircuitParameters:
        """The circuit of one pack: this block, completed with the pack's values.

        Parameters
        ----------
        capacity_ah : float or None
            The pack's capacity per cell. [A h]
        r0_ohm : float, (soc, ohm) or None
            The pack's resistance per cell. [Ω]
        cells_series, cells_parallel : int
            The pack's layout.
        where : str
            The file, for messages.

        Raises
        ------
        InputError
            The block and the pack leave the capacity or R0 unknown, or the values do
            not go together.
        """
        problems = S.Problems(where)
        values = dict(self.values)
        if values["capacity_ah"] is None:
            values["capacity_ah"] = capacity_ah
        if values["r0_ohm"] is None:
            values["r0_ohm"] = r0_ohm
        if values["capacity_ah"] is None:
            problems.add("missing required key 'circuit.capacity_ah' (a number; or "
                         "give the pack's capacity_mah)")
        if values["r0_ohm"] is None:
            problems.add("missing required key 'circuit.r0_ohm' (a number or a table; "
                         "or give the pack's internal_resistance_ohm)")
        problems.done()
        values.update(cells_series=values["cells_series"] or cells_series,
                      cells_parallel=values["cells_parallel"] or cells_parallel)
        try:
            return CircuitParameters(**values)
        except InputError as exc:
            raise InputError(f"{where}: {exc}".replace(": circuit: ", ": circuit.")) from None


def parse_r0(value: Any, key: str, problems: S.Problems):
    """``r0_ohm`` as a file writes it: a number, or ``{soc: [...], ohm: [...]}`` (R0
    against the state of charge, :func:`~planner.physics.battery.circuit.r0_table`).

    Returns the resistance [Ω] or the sorted table, or None with the problem recorded in
    ``problems``, naming ``key`` (the key path, ``circuit.r0_ohm``).
    """
    wrong = f"{key} must be a number or a mapping {{soc: [...], ohm: [...]}}, got {value!r}"
    if isinstance(value, bool):
        problems.add(wrong)
        return None
    if isinstance(value, numbers.Real):
        if math.isfinite(value) and value >= 0:
            return float(value)
        problems.add(f"{key} must be >= 0 (a resistance), got {value!r}")
        return None
    if isinstance(value, dict):
        if set(value) != {"soc", "ohm"}:
            problems.add(f"{key} as a table needs exactly the keys 'soc' and 'ohm', "
                         f"got {sorted(map(str, value))}")
            return None
        value = (value["soc"], value["ohm"])
    if isinstance(value, (tuple, list)) and len(value) == 2:
        try:
            return r0_table(value[0], value[1], name=key)
        except InputError as exc:
            problems.add(str(exc))
            return None
    problems.add(wrong)
    return None


def circuit_block(data: Any, where: str, base_dir: str | Path | None = None) -> CircuitBlock:
    """Validate a ``circuit:`` block (reading its OCV CSV) into a :class:`CircuitBlock`.

    Parameters
    ----------
    data : mapping
        The block.
    where : str
        The file, for messages; ``ocv_csv`` is read relative to its folder unless
        ``base_dir`` is given.
    base_dir : str or Path, optional
        Folder of the relative ``ocv_csv`` path.

    Raises
    ------
    InputError
        Every problem at once, naming ``where`` and the key (an unknown key with the
        likely intended one, a wrong type, an impossible value, a bad OCV file).
    """
    problems = S.Problems(where)
    d = S.check_mapping(data, CIRCUIT_KEYS, where, prefix="circuit.", problems=problems)
    if d["r0_ohm"] is not None:
        d["r0_ohm"] = parse_r0(d["r0_ohm"], "circuit.r0_ohm", problems)
    if (d["r1_ohm"] or 0.0) > 0 and d["c1_f"] is None:
        problems.add("circuit.c1_f is required when circuit.r1_ohm > 0")
    if (d["hysteresis_v"] or 0.0) > 0 and d["hysteresis_gamma"] is None:
        problems.add("circuit.hysteresis_gamma is required when circuit.hysteresis_v > 0")
    if d["hysteresis_gamma"] is None:
        d["hysteresis_gamma"] = _BLANK["hysteresis_gamma"]
    d["ocv"] = _ocv(d["ocv_csv"], where, base_dir, problems)
    problems.done()
    block = CircuitBlock(MappingProxyType(d))
    if block.capacity_ah is not None and block.r0_ohm is not None:
        block.parameters(capacity_ah=None, r0_ohm=None, cells_series=1, cells_parallel=1,
                         where=where)  # the values together (e.g. c1_f with r1_ohm)
    return block


def _ocv(csv: str | None, where: str, base_dir, problems: S.Problems):
    """The OCV curve of ``ocv_csv`` (relative to ``base_dir``, else to the file's folder);
    the LiPo curve without one."""
    if csv is None:
        return lipo_ocv
    path = Path(csv)
    if not path.is_absolute():
        path = Path(base_dir if base_dir is not None else Path(where).parent) / path
    try:
        return read_ocv_csv(path)
    except InputError as exc:
        problems.add(f"circuit.ocv_csv: {exc}")
        return lipo_ocv


def circuit_to_mapping(params: CircuitParameters | CircuitBlock) -> dict[str, Any]:
    """The YAML ``circuit:`` block of circuit parameters (an OCV given only as a callable
    is not written; values the block leaves to the pack are left out)."""
    out: dict[str, Any] = {}
    if params.capacity_ah is not None:
        out["capacity_ah"] = float(params.capacity_ah)
    if isinstance(params.r0_ohm, tuple):
        out["r0_ohm"] = {"soc": [float(x) for x in params.r0_ohm[0]],
                         "ohm": [float(x) for x in params.r0_ohm[1]]}
    elif params.r0_ohm is not None:
        out["r0_ohm"] = float(params.r0_ohm)
    out["r1_ohm"] = float(params.r1_ohm)
    if params.c1_f is not None:
        out["c1_f"] = float(params.c1_f)
    out["hysteresis_v"] = float(params.hysteresis_v)
    out["hysteresis_gamma"] = float(params.hysteresis_gamma)
    if params.ocv_csv:
        out["ocv_csv"] = str(params.ocv_csv)
    out["r0_activation_energy_j_mol"] = float(params.r0_activation_energy_j_mol)
    out["capacity_temp_coeff_per_c"] = float(params.capacity_temp_coeff_per_c)
    out["reference_temperature_c"] = float(params.reference_temperature_c)
    out["coulombic_efficiency"] = float(params.coulombic_efficiency)
    for key in ("cells_series", "cells_parallel"):
        if getattr(params, key) is not None:
            out[key] = int(getattr(params, key))
    if params.source:
        out["source"] = params.source
    return out


def circuit_from_mapping(data: Any, where: str, *, base_dir: str | Path | None = None,
                         capacity_ah: float | None = None, r0_ohm: Any = None,
                         cells_series: int | None = None,
                         cells_parallel: int | None = None) -> CircuitParameters:
    """A ``circuit:`` block completed into circuit parameters in one step
    (:func:`circuit_block`, then :meth:`CircuitBlock.parameters` with the pack's capacity
    per cell [A h], resistance per cell [Ω, or a table] and layout)."""
    problems = S.Problems(where)
    r0 = None if r0_ohm is None else parse_r0(r0_ohm, "r0_ohm", problems)
    problems.done()
    return circuit_block(data, where, base_dir).parameters(
        capacity_ah=capacity_ah, r0_ohm=r0, cells_series=cells_series or 1,
        cells_parallel=cells_parallel or 1, where=where)


# --------------------------------------------------------------------------- thermal

_THERMAL = S.field_defaults(ThermalParameters)

#: Keys of a ``thermal:`` block; the temperatures lie inside the battery models' range.
THERMAL_KEYS = {
    "r_th_k_per_w": S.positive(required=True, unit="K/W",
                               meaning="thermal resistance R_th, pack to air"),
    "c_th_j_per_k": S.positive(required=True, unit="J/K", meaning="heat capacity C_th"),
    "t_air_c": S.between(T_RANGE_C[0], T_RANGE_C[1], default=_THERMAL["t_air_c"], unit="°C",
                         meaning="air temperature (a mission's temperature replaces it)"),
    "t0_c": S.between(T_RANGE_C[0], T_RANGE_C[1], unit="°C",
                      meaning="pack temperature at the start (absent: the air's)"),
    "source": S.text("where the numbers come from"),
}


def _build(cls, data: Any, keys: dict[str, S.Key], where: str, prefix: str,
           together: tuple[str, str] | None = None):
    """Validate a block against ``keys`` and build ``cls`` from it; ``together``: two keys
    given both or neither."""
    problems = S.Problems(where)
    d = S.check_mapping(data, keys, where, prefix=prefix, problems=problems)
    if together and not len(problems) and (d[together[0]] is None) != (d[together[1]] is None):
        problems.add(f"{prefix}{together[0]} and {prefix}{together[1]} come together "
                     "(both or neither)")
    problems.done()
    numbers_ = {k: float(v) for k, v in d.items() if keys[k].kind == S.NUMBER and v is not None}
    try:
        return cls(**{**d, **numbers_})
    except ValueError as exc:
        raise InputError(f"{where}: {exc}") from None


def thermal_from_mapping(data: Any, where: str) -> ThermalParameters:
    """Validate a YAML ``thermal:`` block (:data:`THERMAL_KEYS`) into
    :class:`~planner.physics.battery.thermal.ThermalParameters`.

    Raises
    ------
    InputError
        Every problem at once, naming ``where`` and the key.
    """
    return _build(ThermalParameters, data, THERMAL_KEYS, where, "thermal.")


def thermal_to_mapping(params: ThermalParameters) -> dict[str, Any]:
    """The YAML ``thermal:`` block of lumped thermal parameters."""
    out: dict[str, Any] = {"r_th_k_per_w": float(params.r_th_k_per_w),
                           "c_th_j_per_k": float(params.c_th_j_per_k),
                           "t_air_c": float(params.t_air_c)}
    if params.t0_c is not None:
        out["t0_c"] = float(params.t0_c)
    if params.source:
        out["source"] = params.source
    return out


# --------------------------------------------------------------------------- supercap

_SUPERCAP = S.field_defaults(SupercapParameters)

#: Keys of a ``supercap:`` block (one cell, and the bank layout).
SUPERCAP_KEYS = {
    "c0_f": S.positive(required=True, unit="F",
                       meaning="constant part of the fast-branch capacitance"),
    "cv_f_per_v": S.non_negative(default=_SUPERCAP["cv_f_per_v"], unit="F/V",
                                 meaning="voltage-dependent part of the fast-branch capacitance"),
    "r_fast_ohm": S.positive(required=True, high=L.SUPERCAP_ESR_MAX_OHM, unit="Ω",
                             meaning="fast-branch series resistance (ESR)"),
    "r_slow_ohm": S.positive(unit="Ω", meaning="slow-branch resistance (with c_slow_f)"),
    "c_slow_f": S.positive(unit="F", meaning="slow-branch capacitance (with r_slow_ohm)"),
    "r_leak_ohm": S.positive(unit="Ω", meaning="leakage (self-discharge) resistance"),
    "v_rated_v": S.positive(default=_SUPERCAP["v_rated_v"], high=L.SUPERCAP_VOLTAGE_MAX_V,
                            unit="V", meaning="rated cell voltage"),
    "r_th_k_per_w": S.positive(unit="K/W", meaning="thermal resistance of a cell, case to air"),
    "c_th_j_per_k": S.positive(unit="J/K", meaning="heat capacity of a cell"),
    "mass_kg": S.positive(unit="kg", meaning="mass of a cell"),
    "cells_series": S.count(L.SUPERCAP_CELLS_SERIES_MAX, default=_SUPERCAP["cells_series"],
                            meaning="cells in series"),
    "cells_parallel": S.count(L.CELLS_PARALLEL_MAX, default=_SUPERCAP["cells_parallel"],
                              meaning="cells in parallel"),
    "name": S.text("name shown in the reports", default=_SUPERCAP["name"]),
    "source": S.text("where the numbers come from"),
}


def supercap_from_mapping(data: Any, where: str) -> SupercapParameters:
    """Validate a YAML ``supercap:`` block (:data:`SUPERCAP_KEYS`) into
    :class:`~planner.physics.battery.supercap.SupercapParameters`.

    Raises
    ------
    InputError
        Every problem at once, naming ``where`` and the key.
    """
    return _build(SupercapParameters, data, SUPERCAP_KEYS, where, "supercap.",
                  together=("r_slow_ohm", "c_slow_f"))


def supercap_to_mapping(params: SupercapParameters) -> dict[str, Any]:
    """The YAML ``supercap:`` block of supercapacitor parameters."""
    out: dict[str, Any] = {}
    for key in SUPERCAP_KEYS:
        value = getattr(params, key)
        if value is None or (key in ("name",) and not value):
            continue
        out[key] = value if isinstance(value, str) else (
            int(value) if key.startswith("cells_") else float(value))
    return out

r"""The ``circuit:``, ``thermal:`` and ``supercap:`` blocks of definition files.

Each block is validated once, when its file is loaded, and becomes a typed object: the
``thermal:`` block a :class:`~planner.physics.battery.thermal.ThermalParameters`, the
``supercap:`` block a :class:`~planner.physics.battery.supercap.SupercapParameters`, and the
``circuit:`` block a :class:`CircuitBlock` — the block as written (per cell, with the OCV
table read once), which :meth:`CircuitBlock.parameters` completes from the pack (capacity,
R0 and layout where the block leaves them out) into the
:class:`~planner.physics.battery.circuit.CircuitParameters` the physics runs on.

The keys, units and defaults of each block are tabulated in the module docstring of its
model (:mod:`planner.physics.battery.circuit`, :mod:`planner.physics.battery.thermal`,
:mod:`planner.physics.battery.supercap`); the bounds are the tables below.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from planner.io import schema as S
from planner.physics.battery.circuit import (
    DEFAULT_CAPACITY_TEMP_COEFF,
    DEFAULT_R0_ACTIVATION_J_MOL,
    CircuitParameters,
    parse_r0,
)
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.battery.supercap import SupercapParameters
from planner.physics.battery.thermal import T_RANGE_C, ThermalParameters
from planner.errors import InputError
from planner.parameters.ocv import read_ocv_csv

__all__ = ["CIRCUIT_KEYS", "SUPERCAP_KEYS", "THERMAL_KEYS", "CircuitBlock", "circuit_block",
           "circuit_to_mapping", "supercap_from_mapping", "supercap_to_mapping",
           "thermal_from_mapping", "thermal_to_mapping"]

# --------------------------------------------------------------------------- circuit

#: Keys of a ``circuit:`` block (per cell) and their bounds: a cell of up to 2000 A h
#: (far above any flight cell), resistances up to 10 Ω, a hysteresis of at most 0.5 V
#: (LiPo cells show tens of mV), an activation energy up to 200 kJ/mol (electrode
#: reactions lie near 20–60 kJ/mol), a capacity loss of at most 2 %/°C below the
#: reference temperature, which lies inside the model's range.
CIRCUIT_KEYS = {
    "capacity_ah": S.positive(high=2000.0),
    "r0_ohm": S.Key(S.ANY),
    "r1_ohm": S.non_negative(default=0.0, high=10.0),
    "c1_f": S.positive(),
    "hysteresis_v": S.non_negative(default=0.0, high=0.5),
    "hysteresis_gamma": S.non_negative(high=1e5),
    "ocv_csv": S.Key(S.TEXT),
    "r0_activation_energy_j_mol": S.Key(S.NUMBER, default=DEFAULT_R0_ACTIVATION_J_MOL,
                                        low=0.0, high=200_000.0),
    "capacity_temp_coeff_per_c": S.Key(S.NUMBER, default=DEFAULT_CAPACITY_TEMP_COEFF,
                                       low=0.0, high=0.02),
    "reference_temperature_c": S.Key(S.NUMBER, default=25.0, low=T_RANGE_C[0],
                                     high=T_RANGE_C[1]),
    "coulombic_efficiency": S.Key(S.NUMBER, default=1.0, low=0.0, low_open=True, high=1.0),
    "cells_series": S.Key(S.INTEGER, low=1, high=40),
    "cells_parallel": S.Key(S.INTEGER, low=1, high=100),
    "source": S.Key(S.TEXT),
}


@dataclass(frozen=True, eq=False)
class CircuitBlock:
    """A pack file's ``circuit:`` block, validated, with its OCV table read.

    Every field is the block's value per cell; ``None`` where the block leaves it to the
    pack (``capacity_ah``, ``r0_ohm``, ``cells_series``, ``cells_parallel``). See
    :class:`~planner.physics.battery.circuit.CircuitParameters` for the meaning and units.
    """

    capacity_ah: float | None = None
    r0_ohm: Any = None
    r1_ohm: float = 0.0
    c1_f: float | None = None
    hysteresis_v: float = 0.0
    hysteresis_gamma: float = 0.0
    ocv: Callable = field(default=lipo_ocv)
    ocv_csv: str | None = None
    r0_activation_energy_j_mol: float = DEFAULT_R0_ACTIVATION_J_MOL
    capacity_temp_coeff_per_c: float = DEFAULT_CAPACITY_TEMP_COEFF
    reference_temperature_c: float = 25.0
    coulombic_efficiency: float = 1.0
    cells_series: int | None = None
    cells_parallel: int | None = None
    source: str | None = None

    def parameters(self, *, capacity_ah: float | None, r0_ohm: Any, cells_series: int,
                   cells_parallel: int, where: str = "battery") -> CircuitParameters:
        """The circuit of one pack: this block, completed with the pack's values.

        Raises
        ------
        InputError
            The block and the pack leave the capacity or R0 unknown.
        """
        problems = []
        cap = self.capacity_ah if self.capacity_ah is not None else capacity_ah
        r0 = self.r0_ohm if self.r0_ohm is not None else r0_ohm
        if cap is None:
            problems.append("missing required key 'circuit.capacity_ah' (a number; or "
                            "give the pack's capacity_mah)")
        if r0 is None:
            problems.append("missing required key 'circuit.r0_ohm' (a number or a table; "
                            "or give the pack's internal_resistance_ohm)")
        if problems:
            raise InputError(f"{where}: " + "; ".join(problems))
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update(capacity_ah=cap, r0_ohm=r0,
                      cells_series=self.cells_series or cells_series,
                      cells_parallel=self.cells_parallel or cells_parallel)
        try:
            return CircuitParameters(**values)
        except ValueError as exc:
            raise InputError(f"{where}: {exc}".replace(": circuit: ", ": circuit.")) from None


def circuit_block(data: Any, where: str, base_dir: str | Path | None = None) -> CircuitBlock:
    """Validate a ``circuit:`` block (reading its OCV CSV) into a :class:`CircuitBlock`.

    Parameters
    ----------
    data : mapping
        The block.
    where : str
        The file, for messages; ``ocv_csv`` is read relative to its folder unless
        ``base_dir`` is given.

    Raises
    ------
    InputError
        Every problem at once, naming ``where`` and the key (an unknown key with the
        likely intended one, a wrong type, an impossible value, a bad OCV file).
    """
    problems: list[str] = []
    d = S.check_mapping(data, CIRCUIT_KEYS, where, prefix="circuit.", problems=problems)
    if d["r0_ohm"] is not None:
        d["r0_ohm"] = parse_r0(d["r0_ohm"], "circuit.r0_ohm", problems)
    if (d["r1_ohm"] or 0.0) > 0 and d["c1_f"] is None:
        problems.append("circuit.c1_f is required when circuit.r1_ohm > 0")
    if (d["hysteresis_v"] or 0.0) > 0 and d["hysteresis_gamma"] is None:
        problems.append("circuit.hysteresis_gamma is required when circuit.hysteresis_v > 0")
    if d["hysteresis_gamma"] is None:
        d["hysteresis_gamma"] = 0.0
    d["ocv"] = lipo_ocv
    if d["ocv_csv"] is not None:
        csv = Path(d["ocv_csv"])
        if not csv.is_absolute():
            csv = Path(base_dir if base_dir is not None else Path(where).parent) / csv
        try:
            d["ocv"] = read_ocv_csv(csv)
        except InputError as exc:
            problems.append(f"circuit.ocv_csv: {exc}")
    if problems:
        raise InputError(f"{where}: " + "; ".join(problems))
    block = CircuitBlock(**d)
    if block.capacity_ah is not None and block.r0_ohm is not None:
        block.parameters(capacity_ah=None, r0_ohm=None, cells_series=1, cells_parallel=1,
                         where=where)  # the values together (e.g. c1_f with r1_ohm)
    return block


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
    (:func:`circuit_block`, then :meth:`CircuitBlock.parameters`)."""
    problems: list[str] = []
    r0 = None if r0_ohm is None else parse_r0(r0_ohm, "r0_ohm", problems)
    if problems:
        raise InputError(f"{where}: " + "; ".join(problems))
    return circuit_block(data, where, base_dir).parameters(
        capacity_ah=capacity_ah, r0_ohm=r0, cells_series=cells_series or 1,
        cells_parallel=cells_parallel or 1, where=where)


# --------------------------------------------------------------------------- thermal

#: Keys of a ``thermal:`` block; the temperatures lie inside the battery models' range.
THERMAL_KEYS = {
    "r_th_k_per_w": S.positive(required=True),
    "c_th_j_per_k": S.positive(required=True),
    "t_air_c": S.Key(S.NUMBER, default=25.0, low=T_RANGE_C[0], high=T_RANGE_C[1]),
    "t0_c": S.Key(S.NUMBER, low=T_RANGE_C[0], high=T_RANGE_C[1]),
    "source": S.Key(S.TEXT),
}


def thermal_from_mapping(data: Any, where: str) -> ThermalParameters:
    """Validate a YAML ``thermal:`` block into :class:`ThermalParameters`.

    Raises
    ------
    InputError
        Every problem at once, naming ``where`` and the key.
    """
    d = S.check_mapping(data, THERMAL_KEYS, where, prefix="thermal.")
    try:
        return ThermalParameters(float(d["r_th_k_per_w"]), float(d["c_th_j_per_k"]),
                                 float(d["t_air_c"]),
                                 None if d["t0_c"] is None else float(d["t0_c"]), d["source"])
    except ValueError as exc:
        raise InputError(f"{where}: {exc}") from None


def thermal_to_mapping(params: ThermalParameters) -> dict[str, Any]:
    """The YAML ``thermal:`` block."""
    out: dict[str, Any] = {"r_th_k_per_w": float(params.r_th_k_per_w),
                           "c_th_j_per_k": float(params.c_th_j_per_k),
                           "t_air_c": float(params.t_air_c)}
    if params.t0_c is not None:
        out["t0_c"] = float(params.t0_c)
    if params.source:
        out["source"] = params.source
    return out


# --------------------------------------------------------------------------- supercap

#: Keys of a ``supercap:`` block (one cell, and the bank layout).
SUPERCAP_KEYS = {
    "c0_f": S.positive(required=True),
    "cv_f_per_v": S.non_negative(default=0.0),
    "r_fast_ohm": S.positive(required=True, high=100.0),
    "r_slow_ohm": S.positive(),
    "c_slow_f": S.positive(),
    "r_leak_ohm": S.positive(),
    "v_rated_v": S.positive(default=2.7, high=10.0),
    "r_th_k_per_w": S.positive(),
    "c_th_j_per_k": S.positive(),
    "mass_kg": S.positive(),
    "cells_series": S.Key(S.INTEGER, default=1, low=1, high=500),
    "cells_parallel": S.Key(S.INTEGER, default=1, low=1, high=100),
    "name": S.Key(S.TEXT, default=""),
    "source": S.Key(S.TEXT),
}


def supercap_from_mapping(data: Any, where: str) -> SupercapParameters:
    """Validate a YAML ``supercap:`` block into :class:`SupercapParameters`.

    Raises
    ------
    InputError
        Every problem at once, naming ``where`` and the key.
    """
    problems: list[str] = []
    d = S.check_mapping(data, SUPERCAP_KEYS, where, prefix="supercap.", problems=problems)
    if not problems and (d["r_slow_ohm"] is None) != (d["c_slow_f"] is None):
        problems.append("supercap.r_slow_ohm and supercap.c_slow_f come together "
                        "(both or neither)")
    if problems:
        raise InputError(f"{where}: " + "; ".join(problems))
    try:
        return SupercapParameters(**d)
    except ValueError as exc:
        raise InputError(f"{where}: {exc}") from None


def supercap_to_mapping(params: SupercapParameters) -> dict[str, Any]:
    """The YAML ``supercap:`` block."""
    out: dict[str, Any] = {}
    for key in SUPERCAP_KEYS:
        value = getattr(params, key)
        if value is None or (key in ("name",) and not value):
            continue
        out[key] = value if isinstance(value, str) else (
            int(value) if key.startswith("cells_") else float(value))
    return out

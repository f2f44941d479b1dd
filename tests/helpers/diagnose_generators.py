"""Independent generators of synthetic flight records for the diagnose tests.

Test-only code. Nothing here calls :mod:`planner.identify.diagnose` (whose extensions the
tests must not use to make their own data): the physics is stated anew.

* **Capacity level** — the equivalent-circuit pack model
  (:func:`planner.physics.battery.circuit.simulate`: OCV(SoC), R0 with Arrhenius
  temperature dependence, an RC branch, temperature-dependent capacity) turns a
  power profile into current and voltage; the logger integrates its (noisy,
  possibly biased) current. The effects are physical changes of that pack:
  ``temperature`` switches on the circuit's own cold-capacity loss and R0
  Arrhenius law (a clean pack has neither, while its temperature still varies);
  ``capacity_fade`` shrinks the capacity and raises R0 with the cycle count;
  ``current_offset`` adds a constant bias to the logged current (also at rest).
* **Power level** — a direct re-statement of rotor momentum theory
  (:func:`momentum_power`, below: Glauert's induced velocity solved by bisection,
  profile power growing with advance ratio, parasite and climb power), flown
  along a survey pattern with turbulence and sensor noise. The effects are
  changes of that physics: a steady ``wind`` (the log has only ground speed and
  course), ``air_density`` from the day's pressure and temperature (a clean
  data set logs them too but flies at standard density), a ``payload_change``
  (mass step in flight), a ``system_power`` load and an ``efficiency_curve``
  from a copper loss :math:`R I^2` in the motors.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from planner.physics.battery.circuit import simulate
from planner.parameters import aircraft_from_mapping, battery_from_mapping

G0 = 9.80665
R_AIR = 287.05287

# --------------------------------------------------------------------------- packs

#: The seed paper's test pack (Multistar 10 Ah 4S) with an RC branch.
PACK_10AH = {
    "name": "Multistar 10.0 Ah 4S1P (test)", "cells_series": 4, "capacity_mah": 10000,
    "mass_kg": 0.8, "internal_resistance_ohm": 0.02068,
    "model": {"delta": 23.6482, "epsilon": -1.0209, "beta": 0.9648},
    "circuit": {"r1_ohm": 0.003, "c1_f": 10000.0},
}
#: A 6S 10 Ah pack for the multirotor flights.
PACK_6S = {
    "name": "6S 10 Ah (test)", "cells_series": 6, "capacity_mah": 10000, "mass_kg": 1.3,
    "internal_resistance_ohm": 0.03, "circuit": {"r1_ohm": 0.002, "c1_f": 15000.0},
}


def battery(mapping=None):
    """A BatteryPack from a mapping (default the 10 Ah 4S pack)."""
    return battery_from_mapping(dict(mapping or PACK_10AH), "<test pack>")


def _circuit(pack_map, *, temp_coeff=0.0, activation=0.0, capacity_factor=1.0,
             r0_factor=1.0):
    pack = battery(pack_map)
    p = pack.circuit_parameters()
    return replace(p, capacity_temp_coeff_per_c=temp_coeff, r0_activation_energy_j_mol=activation,
                   capacity_ah=p.capacity_ah * capacity_factor, r0_ohm=p.r0_ohm * r0_factor)


# --------------------------------------------------------------------------- capacity level

def _effects(effect, magnitude) -> dict:
    """``effect`` as a dict name → magnitude (a name with ``magnitude``, a dict, or None)."""
    if effect is None:
        return {}
    if isinstance(effect, dict):
        return dict(effect)
    return {effect: magnitude}


def power_profile(kind: str, duration_s: float, dt_s: float, rng, scale: float = 1.0):
    """A power profile: ``aprbs`` (levels 50–125 W held 30–300 s, some rests), ``flights``
    (take-off, cruise and hover legs with rests between flights) or ``steps``."""
    t = np.arange(0.0, duration_s, dt_s)
    p = np.zeros_like(t)
    now = 0.0
    if kind == "aprbs":
        while now < duration_s:
            hold = rng.uniform(30, 300)
            level = 0.0 if rng.random() < 0.15 else rng.choice([50.0, 75.0, 100.0, 125.0])
            p[(t >= now) & (t < now + hold)] = level
            now += hold
    elif kind == "flights":
        while now < duration_s:
            flight = rng.uniform(500, 900)
            legs_t = now
            while legs_t < now + flight:
                hold = rng.uniform(20, 120)
                level = rng.choice([90.0, 110.0, 140.0]) if legs_t == now else \
                    rng.uniform(70, 130)
                p[(t >= legs_t) & (t < min(legs_t + hold, now + flight))] = level
                legs_t += hold
            now += flight + rng.uniform(120, 400)           # on the ground, load off
    elif kind == "steps":
        while now < duration_s:
            hold = rng.uniform(400, 900)
            p[(t >= now) & (t < now + hold)] = rng.choice([60.0, 90.0, 120.0])
            now += hold
    else:
        raise ValueError(kind)
    return t, p * scale


def capacity_dataset(effect: str | None = None, magnitude: float | None = None, *,
                     n_experiments: int = 10, duration_s: float = 3000.0, dt_s: float = 2.0,
                     profile: str = "aprbs", seed: int = 0, temperature: bool = True,
                     temperature_range=(-10.0, 35.0), cycles=(0, 400), pack_map=None,
                     current_noise_a: float = 0.05, voltage_noise_v: float = 0.01):
    """Discharge experiments of one pack, with ``effect`` hidden at ``magnitude``.

    Effects and magnitudes: ``temperature`` — the circuit's capacity loss per °C below
    25 °C (e.g. 0.006) with R0's Arrhenius law (25 kJ/mol); ``capacity_fade`` — capacity
    loss per cycle (e.g. 5e-4; R0 rises 5× as fast: doubled when 20 % of the capacity is lost); ``current_offset`` — bias of the
    logged current [A] (e.g. 0.15).

    Returns
    -------
    (DataFrame, dict)
        The flight record and the truth (``effect``, ``magnitude``).
    """
    rng = np.random.default_rng(seed)
    pack_map = pack_map or PACK_10AH
    eff = _effects(effect, magnitude)
    frames = []
    cyc = np.sort(rng.integers(cycles[0], cycles[1] + 1, n_experiments))
    cyc[0], cyc[-1] = cycles[0], cycles[1]
    ambient = rng.uniform(*temperature_range, n_experiments)
    for j in range(n_experiments):
        t, p = power_profile(profile, duration_s, dt_s, rng)
        heat = rng.uniform(2.0, 6.0)
        temp = np.clip(ambient[j] + heat * (1 - np.exp(-t / 1200.0)), -19.0, 59.0)
        kw = {}
        if "temperature" in eff:
            kw.update(temp_coeff=eff["temperature"], activation=25_000.0)
        if "capacity_fade" in eff:
            kw.update(capacity_factor=1.0 - eff["capacity_fade"] * cyc[j],
                      r0_factor=1.0 + 5.0 * eff["capacity_fade"] * cyc[j])
        params = _circuit(pack_map, **kw)
        sim = simulate(params, t, power_w=p, temperature_c=temp)
        current = sim.current_a + current_noise_a * rng.standard_normal(t.size)
        voltage = sim.voltage_v + voltage_noise_v * rng.standard_normal(t.size)
        # the load measures its own power (constant-power electronic load, bench test)
        power = sim.power_w * (1 + 0.002 * rng.standard_normal(t.size))
        if "current_offset" in eff:
            current = current + eff["current_offset"]   # the logger's current sensor is biased
        consumed = np.r_[0.0, np.cumsum(0.5 * (current[1:] + current[:-1]) * np.diff(t))] / 3.6
        df = pd.DataFrame({"experiment": f"exp{j:02d}", "time_s": t, "voltage_v": voltage,
                           "current_a": current, "power_w": power,
                           "consumed_mah": consumed})
        if temperature:
            df["temperature_c"] = temp + 0.2 * rng.standard_normal(t.size)
        df["cycle"] = int(cyc[j])
        frames.append(df)
    return pd.concat(frames, ignore_index=True), {"effect": effect, "magnitude": magnitude,
                                                   "cycles": cyc, "ambient_c": ambient}


# --------------------------------------------------------------------------- power level

#: The test multirotor: a 2.8 kg quad with 15-inch rotors (true physics).
QUAD = {"empty_mass_kg": 1.5, "rotors": 4, "rotor_diameter_m": 0.381, "figure_of_merit": 0.62,
        "induced_factor": 1.15, "efficiency": 0.72, "drag_area_m2": 0.04, "system_power_w": 12.0}


def aircraft_file(truth=None, *, efficiency=None, drag_area_m2=None, system_power_w=None):
    """The Aircraft the planner is given: the true geometry, possibly wrong η, f, P_S."""
    q = dict(QUAD, **(truth or {}))
    return aircraft_from_mapping({
        "name": "test quad", "type": "multirotor", "empty_mass_kg": q["empty_mass_kg"],
        "efficiency": q["efficiency"] if efficiency is None else efficiency,
        "system_power_w": q["system_power_w"] if system_power_w is None else system_power_w,
        "multirotor": {"rotors": q["rotors"], "rotor_diameter_m": q["rotor_diameter_m"],
                       "power_model": "momentum", "figure_of_merit": q["figure_of_merit"],
                       "induced_factor": q["induced_factor"],
                       "drag_area_m2": q["drag_area_m2"] if drag_area_m2 is None
                       else drag_area_m2}}, "<test aircraft>")


def glauert_inflow(mu, x):
    """λ = v_i/v_h solving λ² (μ² + (x + λ)²) = 1 by bisection (largest root ≤ 1 + |x|)."""
    mu = np.asarray(mu, float)
    x = np.asarray(x, float)
    lo = np.zeros(np.broadcast(mu, x).shape)
    hi = 1.0 + np.abs(x) + 0 * lo
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        f = mid * mid * (mu * mu + (x + mid) ** 2) - 1.0
        lo = np.where(f < 0, mid, lo)
        hi = np.where(f < 0, hi, mid)
    return 0.5 * (lo + hi)


def momentum_power(mass, rho, airspeed, climb, *, rotors, diameter, fm, kappa, drag_area):
    """Shaft power of a multirotor (Leishman ch. 2 and 5), restated for the tests.

    T = √(W² + D²), D = ½ρV²f; v_h = √(T/(2ρA)); axial inflow V_z = (DV + W V_c)/T,
    in-plane V_xy = √(V² + V_c² − V_z²); λ from Glauert; P = κTv_i + P₀ + DV + WV_c with
    P₀ = (1/FM − κ) T v_h (1 + 4.65 μ²), μ = V_xy/(Ω R), Ω R = v_h √(2/0.01).
    Slow vertical descents use Leishman's measured curve (divided by κ = 1.15).
    """
    w = mass * G0
    area = rotors * math.pi * diameter**2 / 4
    drag = 0.5 * rho * airspeed**2 * drag_area
    thrust = np.sqrt(w**2 + drag**2)
    vh = np.sqrt(thrust / (2 * rho * area))
    vz = (drag * airspeed + w * climb) / thrust
    vxy = np.sqrt(np.maximum(airspeed**2 + climb**2 - vz**2, 0.0))
    lam = glauert_inflow(vxy / vh, vz / vh)
    xd = np.clip(vz / vh, -2.0, 0.0)
    vrs = (1.15 - 1.125 * xd - 1.372 * xd**2 - 1.718 * xd**3 - 0.655 * xd**4) / 1.15
    slow_descent = (vz < 0) & (vxy < 0.5 * vh)
    lam = np.where(slow_descent, vrs, lam)
    vtip = vh * math.sqrt(2 / 0.01)
    profile = (1 / fm - kappa) * thrust * vh * (1 + 4.65 * (vxy / vtip) ** 2)
    return kappa * thrust * lam * vh + profile + drag * airspeed + w * climb


def survey_flight(rng, duration_s, rate_hz, cruise=(3.0, 15.0), profile="survey"):
    """Kinematics of a flight: climb, legs at several speeds, some climbing or descending,
    hovers, a descent; ground time before and after. ``survey``: legs turning by 90–270°;
    ``lawnmower``: long legs back and forth on one axis with short cross legs."""
    t = np.arange(0.0, duration_s, 1.0 / rate_hz)
    gs = np.zeros_like(t)
    course = np.full_like(t, np.nan)
    climb = np.zeros_like(t)
    ground = 20.0
    climb_s = rng.uniform(15, 30)
    climb[(t >= ground) & (t < ground + climb_s)] = rng.uniform(1.5, 3.0)
    now = ground + climb_s
    end = duration_s - 60.0
    heading = axis = rng.uniform(0, 360)
    leg = 0
    while now < end:
        hold = min(rng.uniform(30, 90), end - now)
        m = (t >= now) & (t < now + hold)
        kind = rng.random()
        if kind < 0.15:                                     # hover
            pass
        elif profile == "lawnmower":
            leg += 1
            heading = (axis + (0 if leg % 4 == 0 else 90 if leg % 4 in (1, 3) else 180)) % 360
            hold = min(hold if leg % 2 == 0 else 0.3 * hold, end - now)
            m = (t >= now) & (t < now + hold)
            gs[m] = rng.uniform(*cruise)
            course[m] = heading
        else:
            heading = (heading + rng.choice([90, 180, 270, 135]) + rng.normal(0, 10)) % 360
            gs[m] = rng.uniform(*cruise)
            course[m] = heading
            if kind > 0.7:                                  # climbing or descending leg
                climb[m] = rng.choice([-2.0, -1.0, 1.5, 3.0])
        now += hold
    down = (t >= end) & (t < end + 40.0)
    climb[down] = -1.0
    airborne = (t >= ground) & (t < end + 40.0)
    return t, gs, course, climb, airborne


def power_dataset(effect: str | None = None, magnitude=None, *, n_flights: int = 4,
                  duration_s: float = 900.0, rate_hz: float = 5.0, seed: int = 0,
                  truth=None, turbulence: float = 0.03, pack_map=None,
                  profile: str = "survey",
                  drivers: bool = True, with_battery: bool = True,
                  speed_response: float = 1.0):
    """Multirotor flights with ``effect`` hidden at ``magnitude``; ``speed_response``: the
    share of the rotor model's change of power with airspeed that the aircraft draws (1:
    as the model says).

    ``wind`` — (speed m/s, from deg); ``air_density`` — density range factor (the
    days' density spans ±magnitude around standard, e.g. 0.12); ``payload_change`` —
    mass step [kg] at a random time in each flight (negative: a drop of a payload carried
    from take-off, ``truth["payload_kg"]``, which the caller passes to diagnose); ``system_power``
    — extra constant load [W]; ``efficiency_curve`` — copper-loss coefficient c [1/W] in
    P = M/η + c M² (e.g. 4e-4).

    Returns
    -------
    (DataFrame, dict)
    """
    rng = np.random.default_rng(seed)
    q = dict(QUAD, **(truth or {}))
    pack = battery(pack_map or PACK_6S)
    eff = _effects(effect, magnitude)
    # a drop starts with the payload on board (the pilot gives it as --payload)
    payload = -eff["payload_change"] if eff.get("payload_change", 0.0) < 0 else 0.0
    frames, truth_out = [], {"effect": effect, "magnitude": magnitude, "change_time_s": {},
                             "payload_kg": payload}
    for j in range(n_flights):
        t, gs, course, climb, airborne = survey_flight(rng, duration_s, rate_hz,
                                                       profile=profile)
        n = t.size
        a = np.radians(np.nan_to_num(course))
        vn, ve = gs * np.cos(a), gs * np.sin(a)
        wn = we = 0.0
        if "wind" in eff:
            speed, frm = eff["wind"]
            wn = -speed * math.cos(math.radians(frm))
            we = -speed * math.sin(math.radians(frm))
        airspeed = np.hypot(vn - wn, ve - we)
        # the day: site pressure and air temperature
        t_air = rng.uniform(-5.0, 35.0)
        pressure = rng.uniform(88_000.0, 102_000.0)
        rho_day = pressure / (R_AIR * (t_air + 273.15))
        if "air_density" in eff:
            # flights spread over sites/days whose density spans ±magnitude around standard,
            # flown at the density of the air the record logs at the aircraft's height
            rho_day = 1.225 * (1 + eff["air_density"] * (2 * j / max(n_flights - 1, 1) - 1))
            pressure = rho_day * R_AIR * (t_air + 273.15)
            height = np.cumsum(climb) / rate_hz
            rho = (pressure - 12.0 * height) / (R_AIR * (t_air - 0.0065 * height + 273.15))
        else:
            rho = np.full(n, 1.225)
        mass = np.full(n, q["empty_mass_kg"] + pack.mass_kg + truth_out["payload_kg"])
        if "payload_change" in eff:
            air_t = t[airborne]
            tc = float(rng.uniform(air_t[0] + 0.3 * (air_t[-1] - air_t[0]),
                                   air_t[0] + 0.7 * (air_t[-1] - air_t[0])))
            mass = np.where(t >= tc, mass + eff["payload_change"], mass)
            truth_out["change_time_s"][f"flight{j}"] = tc
        shaft = momentum_power(mass, rho, airspeed, climb, rotors=q["rotors"],
                               diameter=q["rotor_diameter_m"], fm=q["figure_of_merit"],
                               kappa=q["induced_factor"], drag_area=q["drag_area_m2"])
        if speed_response != 1.0:
            still = momentum_power(mass, rho, np.zeros(n), climb, rotors=q["rotors"],
                                   diameter=q["rotor_diameter_m"], fm=q["figure_of_merit"],
                                   kappa=q["induced_factor"], drag_area=q["drag_area_m2"])
            shaft = still + speed_response * (shaft - still)
        ps = q["system_power_w"] + eff.get("system_power", 0.0)
        electric = shaft / q["efficiency"]
        if "efficiency_curve" in eff:
            electric = electric + eff["efficiency_curve"] * shaft**2
        alpha = math.exp(-1.0 / (2.0 * rate_hz))
        gust = lfilter([math.sqrt(1 - alpha**2)], [1.0, -alpha], rng.standard_normal(n))
        power = np.where(airborne, electric * (1 + turbulence * gust), 0.0) + ps
        alt = np.cumsum(climb) / rate_hz
        df = pd.DataFrame({"experiment": f"flight{j}", "time_s": t,
                           "power_w": power, "altitude_m": alt,
                           "climb_rate_ms": climb + 0.05 * rng.standard_normal(n),
                           "groundspeed_ms": np.abs(gs + 0.1 * rng.standard_normal(n)),
                           "course_deg": np.where(gs > 0.5, course, np.nan)})
        if drivers:
            df["pressure_pa"] = pressure - 12.0 * alt + 20 * rng.standard_normal(n)
            df["ambient_temperature_c"] = t_air - 0.0065 * alt + 0.3 * rng.standard_normal(n)
        if with_battery:
            params = _circuit(pack_map or PACK_6S)
            sim = simulate(params, t, power_w=power, temperature_c=25.0)
            cur = sim.current_a + 0.05 * rng.standard_normal(n)
            volt = sim.voltage_v + 0.01 * rng.standard_normal(n)
            df["voltage_v"] = volt
            df["current_a"] = cur
            df["power_w"] = volt * cur
            df["consumed_mah"] = np.r_[0.0, np.cumsum(0.5 * (cur[1:] + cur[:-1]) / rate_hz)] \
                / 3.6
        frames.append(df)
    return pd.concat(frames, ignore_index=True), truth_out

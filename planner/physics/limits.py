"""Physical limits of the numbers in aircraft and battery files, each with its reason.

The planner is for small electric UAVs; these bounds are wide enough for the largest
electric UAVs flown and keep every model finite (a value like 1e308 otherwise overflows,
or ends in NaN and inf deep inside a run). Each is checked when a file is loaded, by the
key tables of :mod:`planner.parameters.pack` and :mod:`planner.parameters.aircraft`.
"""

#: Any mass: empty aircraft, maximum take-off, one pack. NASA's solar Helios, the
#: largest electric UAV flown, weighed up to about 930 kg. [kg]
MASS_MAX_KG = 1000.0
#: Any airspeed or ground speed. Record-setting racing quadcopters have flown near
#: 130 m/s; small survey UAVs cruise at 5–30 m/s, and above ~100 m/s (Mach 0.3) the
#: incompressible drag polar stops holding anyway. [m/s]
SPEED_MAX_MS = 150.0
#: Least fixed-wing airspeed. The induced power B/V of the polar grows without bound as
#: V → 0; no wing, not even a paper dart, flies at 1 m/s. [m/s]
AIRSPEED_MIN_MS = 1.0
#: Least multirotor cruise ground speed: at 0.1 m/s a 1 km leg already lasts close to
#: three hours. (The top airspeed takes AIRSPEED_MIN_MS: the best-speed search of
#: ``check`` starts at 0.5 m/s.) [m/s]
GROUNDSPEED_MIN_MS = 0.1
#: Default climb and descent rates. Autopilot defaults are 1–3 m/s (ArduCopter
#: WPNAV_SPEED_UP 2.5 m/s, WPNAV_SPEED_DN 1.5 m/s); 50 m/s leaves room for racing
#: quadcopters. [m/s]
VERTICAL_SPEED_MAX_MS = 50.0
#: Any electric power (avionics and payload load, efficiency reference). A 1000 kg
#: multirotor hovers on some 200–400 kW. [W]
POWER_MAX_W = 1.0e6
#: Capacity of one pack: from a 1 mAh coin cell (smaller than any flight pack) to
#: 1000 Ah, far above the tens of Ah of the largest UAV packs. [mAh]
CAPACITY_MIN_MAH, CAPACITY_MAX_MAH = 1.0, 1.0e6
#: Continuous discharge rating. Marketed LiPo ratings stop near 150 C. [1/h]
DISCHARGE_C_MAX = 1000.0
#: Wing reference area: a 15 cm micro air vehicle has about 0.02 m², Helios (75 m span,
#: 2.4 m chord) about 180 m². [m²]
WING_AREA_MIN_M2, WING_AREA_MAX_M2 = 0.005, 500.0
#: Steepest bank of a sustained loiter turn (load factor 2). Autopilots default lower:
#: ArduPlane ROLL_LIMIT_DEG 45°, PX4 FW_R_LIM 50°. [deg]
LOITER_BANK_MAX_DEG = 60.0
#: Widest loiter circle: beyond 10 km a loiter is a route, not a hold. [m]
LOITER_RADIUS_MAX_M = 1.0e4
#: Rotor diameter: nano-quadcopter propellers are about 30 mm, the rotors of
#: crewed-size electric multicopters about 2 m (the existing 5 m bound stays). [m]
ROTOR_DIAMETER_MIN_M, ROTOR_DIAMETER_MAX_M = 0.02, 5.0
#: Static propeller coefficients (rev/s convention) lie near C_T 0.05–0.2 and C_P
#: 0.02–0.1 for small propellers (Brandt and Selig 2011); the lower bounds are 10 times
#: below that, where the rotor speed of the propeller model runs away. [unitless]
CT_MIN, CP_MIN = 0.005, 0.002
#: Rotor tip speed: small propellers run their tips at some 100–250 m/s; at 10 m/s a
#: rotor barely turns, and a tip at the speed of sound (340 m/s, ISA sea level) is
#: beyond the model. [m/s]
TIP_SPEED_MIN_MS, TIP_SPEED_MAX_MS = 10.0, 340.0
#: Maximum total thrust: a thrust-to-weight ratio of 10 on a 1000 kg aircraft. [N]
THRUST_MAX_N = 1.0e5
#: Lower end of a multirotor's airspeed range in the best-speed searches: it hovers at
#: 0 m/s, but the range speed search needs a positive start. [m/s]
MULTIROTOR_MIN_AIRSPEED_MS = 0.5
#: Least propulsion efficiency, battery to useful power: the propulsion fits allow no
#: less than 0.1–0.2; below 0.05 the aircraft is a heater. [unitless]
EFFICIENCY_MIN = 0.05
#: Least drive efficiency (ESC and wiring, battery to motor terminals) of the rotor-loss
#: model: ESCs of small UAVs convert at 0.85–0.98; below 0.3 the wiring would melt before
#: the aircraft flew. [unitless]
DRIVE_EFFICIENCY_MIN = 0.3
#: Longest delay between the power and the flight-state channels of a log the fits and
#: replay correct for: sensor buses of small UAVs are synchronised to about 0.1–0.3 s; a
#: lead beyond 1 s is a clock error, not a delay. [s]
POWER_LEAD_MAX_S = 1.0

# ---------------------------------------------------------------------------------------
# Bounds of the other keys of the definition files (planner.parameters key tables). Each
# is a sanity bound on input: far outside what flies, so that a typo or a unit slip is
# refused with the file and the key named instead of running on.

#: Reciprocal-efficiency slope η1 of the efficiency-against-load curve: η stays in (0, 1],
#: so over the ±100 % of load the reference spans, |η1| of more than 1 would carry it out
#: of that range. [unitless]
EFFICIENCY_SLOPE_MAX = 1.0
#: Spread of a power model's whole-flight energy error (a fraction): calibrated models
#: miss by a few per cent, uncalibrated ones by tens; beyond 1 (100 %) a fraction was
#: written as a per cent. [unitless]
ENERGY_ERROR_SD_MAX = 1.0
#: Least reference mechanical power of the efficiency curve: no aircraft flies on 1 W. [W]
REFERENCE_POWER_MIN_W = 1.0
#: Zero-lift drag coefficient: flying airframes lie at 0.01–0.1; a flat plate across the
#: flow has about 1.2, so 0.5 is no wing. [unitless]
CD0_MAX = 0.5
#: Induced-drag factor K = 1/(π e AR): 0.02–0.1 for UAV wings (AR 6–20, e 0.7–0.9); 1 is
#: an aspect ratio of about 0.3. [unitless]
INDUCED_DRAG_FACTOR_MAX = 1.0
#: Aspect ratio: below 1 a planform is no wing; sailplanes reach 50 (eta: 51). [unitless]
ASPECT_RATIO_MIN, ASPECT_RATIO_MAX = 1.0, 60.0
#: Oswald efficiency e: 1 is the elliptic ideal, measured wings lie at 0.6–0.9; 0.3 is far
#: below any wing. [unitless]
OSWALD_EFFICIENCY_MIN = 0.3
#: Propellers of a fixed-wing aircraft: one to four on most UAVs, 14 on NASA's X-57
#: Maxwell wing. [count]
PROPELLERS_MAX = 16
#: Induced-power factor κ of a propeller in forward flight (1 = ideal momentum theory):
#: a non-uniform, lightly loaded inflow raises it above the 1.1–1.25 of hovering rotors;
#: 3 leaves room for poor fits. [unitless]
PROPELLER_INDUCED_FACTOR_MAX = 3.0
#: Induced-power factor κ of a hovering multirotor rotor: 1.1–1.25 measured (Leishman,
#: Principles of Helicopter Aerodynamics, 2nd ed., 2006, ch. 3); 2 would double the ideal
#: induced power. [unitless]
ROTOR_INDUCED_FACTOR_MAX = 2.0
#: Weight of momentum theory's inflow against Leishman's vortex-ring curve in slow axial
#: descent (planner.physics.power.momentum.induced_velocity, "Slow descent"): at 2 the
#: induced velocity keeps its hover value to first order, so the shaft power falls by
#: nearly the descent's whole rate of potential energy W|V_c|, the most an ideal rotor
#: gives back; at −1 it rises as the descent begins by up to 0.43 W|V_c| near hover, as
#: the vortex ring's power settling does on some rotors. [unitless]
DESCENT_INFLOW_WEIGHT_MIN, DESCENT_INFLOW_WEIGHT_MAX = -1.0, 2.0
#: Rotors of a multirotor: up to eight on most, 18 on the Volocopter 2X. [count]
ROTORS_MAX = 32
#: Upper end of the static propeller coefficients C_T and C_P (rev/s convention), five to
#: ten times the 0.05–0.2 and 0.02–0.1 of small propellers (Brandt and Selig 2011). [unitless]
CT_MAX, CP_MAX = 1.0, 1.0
#: Drag area f = C_D A of a multirotor's body: small quadcopters have 0.01–0.05 m²; a
#: 1000 kg multicopter of 3 m² frontal area at C_D 1 has 3 m². [m²]
DRAG_AREA_MAX_M2 = 10.0
#: Least rotor figure of merit: FM ≤ 1 by definition, small rotors reach 0.5–0.75; below
#: 0.2 the profile power would be four times the ideal. [unitless]
FIGURE_OF_MERIT_MIN = 0.2
#: Cells in series: UAV packs run 1S–14S, heavy lifters up to 24S; 40 LiPo cells are
#: 168 V at full charge. [count]
CELLS_SERIES_MAX = 40
#: Cells in parallel: packs built of 18650 or 21700 cells reach tens in parallel. [count]
CELLS_PARALLEL_MAX = 100
#: Identical packs flown in parallel: one or two on most UAVs, up to 12 on heavy
#: lifters. [count]
PACKS_MAX = 16
#: Resistance of a pack: LiPo cells have 2–20 mΩ, so a 40-cell string of 50 mΩ cells has
#: 2 Ω. [Ω]
PACK_RESISTANCE_MAX_OHM = 10.0
#: Cut-off cell voltage under load: LiPo 3.0–3.5 V, LiFePO4 2.0–2.5 V; at 4.2 V (a full
#: LiPo) nothing could be drawn. [V]
CELL_CUTOFF_MIN_V, CELL_CUTOFF_MAX_V = 2.0, 4.2
#: Price of a pack, in any currency: keeps the totals of ``select`` finite. [currency]
PRICE_MAX = 1.0e9
#: The integral model's δ (t = δ P^ε C^β): its unit follows ε and β, so only its magnitude
#: is bounded; fitted and literature values lie near 10–30, and within 1e±20 P^ε C^β stays
#: finite. [unit of t P^-ε C^-β]
INTEGRAL_DELTA_MIN, INTEGRAL_DELTA_MAX = 1.0e-20, 1.0e20
#: The integral model's power exponent ε: about −1 (the discharge time halves as the
#: power doubles); fits on LiPo packs give −1.0 to −1.3. [unitless]
INTEGRAL_EPSILON_MIN, INTEGRAL_EPSILON_MAX = -3.0, 0.5
#: The integral model's charge exponent β: 0.9648 in [UAV23] eq. 16–17, 1 in the Peukert
#: form. [unitless]
INTEGRAL_BETA_MIN, INTEGRAL_BETA_MAX = 0.5, 1.5
#: Relative change of the charge drawn per °C below the reference temperature (diagnose's
#: temperature effect): LiPo packs lose about 0.5–1 %/°C. [1/°C]
CHARGE_TEMPERATURE_COEFF_MAX_PER_C = 0.2
#: Reference temperature of the integral model's extensions: the temperatures a pack is
#: flown and stored at. [°C]
MODEL_REFERENCE_TEMPERATURE_MIN_C, MODEL_REFERENCE_TEMPERATURE_MAX_C = -40.0, 80.0
#: Relative rise of the charge drawn per charge cycle: a LiPo pack loses about 20 % over
#: 300–1000 cycles (0.02–0.07 %/cycle); a negative value (a pack that gains) is a fit
#: within its error. [1/cycle]
FADE_PER_CYCLE_MIN, FADE_PER_CYCLE_MAX = -0.01, 0.05
#: Charge cycles of a pack: LiPo packs last 300–1000 cycles. [cycles]
CYCLES_MAX = 1.0e5
#: Capacity of one cell of the equivalent circuit: far above any flight cell (a 21700 cell
#: holds 5 A h, the largest prismatic cells some hundreds). [A h]
CELL_CAPACITY_MAX_AH = 2000.0
#: A resistance of the equivalent circuit per cell (R1): cells have 1–50 mΩ. [Ω]
CELL_RESISTANCE_MAX_OHM = 10.0
#: Largest hysteresis voltage M: LiPo cells show tens of mV, LiFePO4 cells some 50 mV. [V]
HYSTERESIS_MAX_V = 0.5
#: Largest hysteresis rate γ: the hysteresis settles within some 3 Q/γ of charge; at 1e5
#: that is a few millionths of the capacity. [unitless]
HYSTERESIS_GAMMA_MAX = 1.0e5
#: Arrhenius activation energy of R0: electrode reactions and the electrolyte lie near
#: 17–60 kJ/mol. [J/mol]
ACTIVATION_ENERGY_MAX_J_MOL = 200_000.0
#: Capacity loss per °C below the reference temperature: about 0.6 %/°C for Li-ion cells
#: down to −20 °C (Zhang, Xu and Jow 2003); 2 %/°C would leave nothing at −25 °C. [1/°C]
CAPACITY_TEMP_COEFF_MAX_PER_C = 0.02
#: Series resistance (ESR) of one supercapacitor cell: large cells have 0.1–1 mΩ, the
#: smallest coin cells some tens of Ω. [Ω]
SUPERCAP_ESR_MAX_OHM = 100.0
#: Rated voltage of one supercapacitor cell: 2.5–3.0 V for EDLC cells, about 3.8 V for
#: lithium-ion capacitors. [V]
SUPERCAP_VOLTAGE_MAX_V = 10.0
#: Supercapacitor cells in series: a 1000 V bank of 2.7 V cells has 370. [count]
SUPERCAP_CELLS_SERIES_MAX = 500
#: Disk loading, take-off weight over total rotor disk area: small multirotors fly at
#: 50–200 N/m², heavy-lift ones and helicopters up to some 700 N/m² (CH-53E about
#: 720 N/m²). Beyond this no rotor of the given size lifts the mass: the mass was written in
#: another unit. [N/m²]
DISK_LOADING_MAX_N_M2 = 2000.0
#: Wing loading, take-off weight over wing area: small UAVs fly at 30–300 N/m², airliners
#: at some 6000 N/m². Beyond this no small electric aircraft of the given wing flies. [N/m²]
WING_LOADING_MAX_N_M2 = 6000.0
#: Specific energy of a battery pack, from its nominal energy and mass: LiFePO4 packs hold
#: about 90 Wh/kg, LiPo 130–200 Wh/kg, the best Li-ion cells some 270 Wh/kg; outside this
#: range the mass or the capacity was written in another unit. [Wh/kg]
PACK_SPECIFIC_ENERGY_MIN_WH_KG, PACK_SPECIFIC_ENERGY_MAX_WH_KG = 20.0, 500.0
#: Horizontal and vertical acceleration of waypoint navigation. Autopilot defaults are
#: 1–3 m/s² (ArduCopter WPNAV_ACCEL 2.5 m/s², PX4 MPC_ACC_HOR 3 m/s²); a multirotor's
#: thrust tilted by 70° gives about 27 m/s², so 30 m/s² bounds any real vehicle. [m/s²]
NAV_ACCEL_MAX_MS2 = 30.0
#: Jerk of waypoint navigation: defaults 1–4 m/s³ (ArduCopter WPNAV_JERK range 1–20,
#: PX4 MPC_JERK_AUTO 4); 500 m/s³ is a step in acceleration for any leg time. [m/s³]
NAV_JERK_MAX_MS3 = 500.0
#: Spin-up on the ground before lift-off and dwell at a waypoint: seconds for an
#: autopilot (ArduCopter MOT_SPOOL_TIME 0.5 s, PX4 COM_SPOOLUP_TIME 1 s); ten minutes
#: bounds a waypoint wait that is a typo for something else. [s]
NAV_WAIT_MAX_S = 600.0
#: Height of the slow final stage of a landing (ArduCopter LAND_ALT_LOW 10 m, PX4
#: MPC_LAND_ALT2 5 m). [m]
LANDING_SLOW_HEIGHT_MAX_M = 500.0

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

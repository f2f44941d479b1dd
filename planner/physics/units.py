"""Unit conversions at the edges of the planner.

SI inside the code (s, m, kg, W, V, A, charge in A·s); mAh, Ah, Wh and hours only where
files and reports use them (the units of the file formats, ``docs/formats.md``). Each
conversion factor is defined here once.
"""

#: Charge of one milliampere-hour in coulombs (ampere-seconds). [A s / mAh]
AS_PER_MAH = 3.6
#: Charge of one ampere-hour in coulombs (ampere-seconds). [A s / Ah]
AS_PER_AH = 3600.0
#: Energy of one watt-hour in joules. [J / Wh]
J_PER_WH = 3600.0
#: Seconds in an hour. [s / h]
S_PER_H = 3600.0
#: Zero of the Celsius scale. [K]
ZERO_CELSIUS_K = 273.15

"""Unit conversions at the edges of the planner.

SI inside the code (s, m, kg, W, V, A, charge in A·s); mAh and Wh only where files and
reports use them (DESIGN §3). Each conversion factor is defined here once.
"""

#: Charge of one milliampere-hour in coulombs (ampere-seconds). [A s / mAh]
AS_PER_MAH = 3.6
#: Energy of one watt-hour in joules. [J / Wh]
J_PER_WH = 3600.0
#: Zero of the Celsius scale. [K]
ZERO_CELSIUS_K = 273.15

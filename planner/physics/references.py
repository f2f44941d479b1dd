"""Citation keys of the papers the planner builds on.

Docstrings cite an equation as ``[UAV23] eq. 14`` or ``[HESS] eq. 11``; the keys resolve
here. Other sources are cited in full where they are used.
"""

#: Citation key → full reference (IEEE style, with the DOI where there is one).
REFERENCES = {
    "UAV23": ('"Battery Testing and Discharge Model Validation for Electric Unmanned Aerial '
              'Vehicles (UAV)," Sensors, vol. 23, no. 15, 6937, 2023, '
              "doi:10.3390/s23156937 (CC BY 4.0). The integral capacity model (eq. 14), its "
              "constant-power form (eq. 15), the literature start values (eq. 16-17), the "
              "fit (eq. 18), the metrics (eq. 20, 29, 30), the amended VDA resistance "
              "(eq. 11), the power models (eq. 2-6 fixed-wing, 9-10 and 22-24 multirotor) "
              "and the two-step test design (eq. 25-28); Tables 1-5."),
    "HESS": ("S. Fiorenti, J. Guanetti, Y. Guezennec and S. Onori, \"Modeling and "
             "experimental validation of a hybridized energy storage system for automotive "
             "applications,\" Center for Automotive Research, The Ohio State University. "
             "State of charge (eq. 1), terminal voltage (eq. 2), R0 from a pulse (eq. 3), "
             "hysteresis (eq. 4), RC branch (eq. 5), two-branch supercapacitor (eq. 6-9), "
             "heat (eq. 10), lumped thermal model (eq. 11), the passive hybrid (eq. 12-14); "
             "Table 3."),
}


def cite(key: str) -> str:
    """The full reference of a citation key (``KeyError`` names the unknown key)."""
    return REFERENCES[key]

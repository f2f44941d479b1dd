"""The route of a checked mission as KML (Google Earth, QGIS, most GIS tools), written with
the standard library.

One placemark per leg (a ``LineString`` from the leg's start to its end, coloured by the
charge left at its end), with the leg's figures as ``ExtendedData``, and point placemarks
for home, the landing, the point of no return and the worst return-home point.
Coordinates are longitude, latitude (WGS-84, degrees) and altitude above mean sea level
(``altitudeMode`` ``absolute``), following the OGC KML 2.2 standard (OGC 07-147r2,
§9.7 ``kml:coordinates``, §9.12 ``kml:LineString``).

The input is the JSON form of a check (:meth:`planner.chain.result.MissionResult.to_dict`)
whose legs carry ``start_lat_deg`` … ``end_alt_amsl_m``
(:func:`planner.chain.mission_chain.route_columns`).
"""

from __future__ import annotations

import math
from typing import Any
from xml.sax.saxutils import escape

from planner.errors import InputError
from planner.physics.geo import aeqd_to_latlon

#: Per-leg figures written as ExtendedData: key of the leg table → (display name, unit,
#: decimals); a fraction is written as a percentage.
LEG_FIELDS = {
    "kind": ("leg", "", None), "origin": ("from", "", None),
    "start_time_s": ("start", "s", 0), "duration_s": ("duration", "s", 0),
    "distance_m": ("distance", "m", 0), "airspeed_ms": ("airspeed", "m/s", 1),
    "groundspeed_ms": ("ground speed", "m/s", 1), "climb_rate_ms": ("climb rate", "m/s", 1),
    "power_w": ("power", "W", 1), "current_a": ("current", "A", 1),
    "voltage_v": ("loaded voltage", "V", 2), "charge_mah": ("charge drawn", "mAh", 0),
    "remaining_fraction": ("charge left at the end", "% of nominal", 1),
    "rtl_margin_mah": ("return-home margin over the reserve", "mAh", 0),
}


def _colour(fraction: float | None) -> str:
    """KML colour (aabbggrr) of a charge left: red at 0, yellow at 50 %, green at 100 %."""
    if fraction is None or not math.isfinite(fraction):
        return "ff888888"
    f = min(max(fraction, 0.0), 1.0)
    r, g = (255, int(510 * f)) if f < 0.5 else (int(510 * (1 - f)), 255)
    return f"ff00{g:02x}{r:02x}"


def _value(key: str, v: Any) -> str:
    _, unit, digits = LEG_FIELDS[key]
    if v is None:
        return "–"
    if digits is None:
        return str(v)
    if key == "remaining_fraction":
        v = 100.0 * v
    return f"{v:.{digits}f} {unit}".strip()


def _point(name: str, lon: float, lat: float, alt: float, description: str = "",
           style: str = "") -> str:
    return (f"<Placemark><name>{escape(name)}</name>"
            + (f"<description>{escape(description)}</description>" if description else "")
            + (f"<styleUrl>#{style}</styleUrl>" if style else "")
            + f"<Point><altitudeMode>absolute</altitudeMode><coordinates>{lon:.7f},"
              f"{lat:.7f},{alt:.1f}</coordinates></Point></Placemark>")


def route_kml(routes: list[tuple[str, dict]], home: tuple[float, float, float], name: str,
              where: str = "KML") -> str:
    """The KML document of one or more checked routes (``routes``: (name, the check's
    :meth:`MissionResult.to_dict`) pairs, e.g. the sorties of a plan, each in its own
    folder) flown from ``home`` (latitude, longitude [deg], altitude above mean sea level
    [m])."""
    if home is None:
        raise InputError(f"{where}: the mission has no home position (latitude, "
                         "longitude): a legs-form YAML mission needs 'home' to be placed "
                         "on a map")
    lat0, lon0, alt0 = home[0], home[1], float(home[2] or 0.0)
    styles: dict[str, str] = {}
    folders = []
    for title, check in routes:
        folders.append(f"<Folder><name>{escape(title)}</name>"
                       f"<description>{escape(check.get('summary', ''))}</description>"
                       + _legs(check["legs"], alt0, styles)
                       + _marks(check, lat0, lon0, alt0) + "</Folder>")
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           '<kml xmlns="http://www.opengis.net/kml/2.2"><Document>',
           f"<name>{escape(name)}</name>"]
    for colour, style in styles.items():
        out.append(f'<Style id="{style}"><LineStyle><color>{colour}</color><width>4</width>'
                   "</LineStyle></Style>")
    out.append(_point("home", lon0, lat0, alt0, "take-off"))
    out.extend(folders)
    out.append("</Document></kml>")
    return "\n".join(out) + "\n"


def _legs(legs: list[dict], alt0: float, styles: dict[str, str]) -> str:
    """One LineString placemark per leg, coloured by the charge left at its end."""
    body = []
    for i, leg in enumerate(legs, 1):
        colour = _colour(leg.get("remaining_fraction"))
        style = styles.setdefault(colour, f"charge{len(styles)}")
        data = "".join(f'<Data name="{escape(LEG_FIELDS[k][0])}"><value>'
                       f"{escape(_value(k, leg.get(k)))}</value></Data>"
                       for k in LEG_FIELDS if k in leg)
        coords = " ".join(f"{leg[f'{e}_lon_deg']:.7f},{leg[f'{e}_lat_deg']:.7f},"
                          f"{leg[f'{e}_alt_m'] + alt0:.1f}" for e in ("start", "end"))
        body.append(f"<Placemark><name>{i} {escape(str(leg['kind']))}</name>"
                    f"<styleUrl>#{style}</styleUrl><ExtendedData>{data}</ExtendedData>"
                    "<LineString><altitudeMode>absolute</altitudeMode>"
                    f"<coordinates>{coords}</coordinates></LineString></Placemark>")
    return "".join(body)


def _marks(check: dict, lat0: float, lon0: float, alt0: float) -> str:
    """The landing, the point of no return and the worst return-home point."""
    last = check["legs"][-1]
    out = [_point("landing", last["end_lon_deg"], last["end_lat_deg"],
                  last["end_alt_m"] + alt0,
                  f"charge left {_value('remaining_fraction', last.get('remaining_fraction'))}")]
    for key, label in (("point_of_no_return", "point of no return"),
                       ("worst_return", "worst return home")):
        p = check.get(key)
        if not p:
            continue
        lat, lon = aeqd_to_latlon(p["east_m"], p["north_m"], lat0, lon0)
        margin = p.get("rtl_margin_mah")
        text = (f"t = {p['time_s']:.0f} s, {p['leg_origin']}, {p['distance_home_m']:.0f} m "
                f"from home; return-home margin "
                + ("home out of reach" if margin is None else f"{margin:+.0f} mAh"))
        out.append(_point(label, float(lon), float(lat), p["altitude_m"] + alt0, text))
    return "".join(out)

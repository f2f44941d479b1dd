"""``--map`` and ``--kml``: the route of a checked mission, drawn (PNG, no map tiles) and
as KML for Google Earth and GIS tools. Shared by ``check`` and ``select``."""

from __future__ import annotations

from planner.cli.commands.common import output_path, plot_path
from planner.errors import InputError
from planner.io import files


def add_route_options(parser, what: str = "the route") -> None:
    """Add ``--map`` (a PNG of ``what``) and ``--kml`` (the same for Google Earth and GIS) to
    ``parser``."""
    parser.add_argument("--map", metavar="F.png", dest="route_map",
                        help=f"write a map of {what} in metres east/north of home: legs "
                             "coloured by the charge left, point of no return, worst "
                             "return home, wind, scale")
    parser.add_argument("--kml", metavar="F.kml",
                        help=f"write {what} as KML (Google Earth, GIS) with each leg's "
                             "figures; needs the mission's home position")


def route_paths(args, mission) -> tuple[str | None, str | None]:
    """The checked ``--map`` and ``--kml`` paths (before any work: a KML of a mission
    without a home position is refused here)."""
    map_out = plot_path(args.route_map, "--map")
    kml_out = output_path(args.kml, "--kml")
    if kml_out is not None and mission.home is None:
        raise InputError(f"--kml: {mission.source or mission.name} has no home position "
                         "(latitude, longitude): give the legs-form YAML a 'home' to place "
                         "it on a map")
    return map_out, kml_out


def write_route(map_out, kml_out, result, mission, title: str | None = None) -> None:
    """The map and the KML of one check (:class:`planner.chain.result.MissionResult`)."""
    if kml_out:
        from planner.io.kml import route_kml

        name = f"{mission.name}: {result.verdict}"
        files.write_text(kml_out, route_kml([(name, result.to_dict())], mission.home, name),
                         "--kml")
    if map_out:
        from planner.cli.plots.route_map import save_route_map

        save_route_map(result, map_out, title=title)


def write_sorties_route(map_out, kml_out, plan, mission, title: str | None = None) -> None:
    """The sorties of a plan: one map and one KML, each sortie in its own colour (map) or
    folder (KML)."""
    if map_out:
        from planner.cli.plots.route_map import save_sorties_map

        save_sorties_map(plan, map_out, title=title)
    if kml_out:
        from planner.io.kml import route_kml

        routes = [(f"flight {s.number}: {s.result.verdict}", s.result.to_dict())
                  for s in plan.sorties]
        files.write_text(kml_out, route_kml(routes, mission.home,
                                            f"{mission.name}: {plan.count} sorties"),
                         "--kml")

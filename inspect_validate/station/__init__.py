"""A station: its file (camera, controller, illuminations, scene, regions, acceptance),
its simulated world, the model of the station as built, and its devices and capture.

The names below are read from :mod:`.file` on first use: a module of this package (the
world's schema, which the simulated devices import while the station file's schema asks
the registry for them) must not pull in the station file's."""

__all__ = ["Illumination", "Station", "read_station", "station_hash", "write_station"]


def __getattr__(name: str):
    if name in __all__:
        from inspect_validate.station import file

        return getattr(file, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

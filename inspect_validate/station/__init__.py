"""A station: its file (camera, controller, illuminations, scene, regions, acceptance),
its simulated world, the model of the station as built, and its devices and capture.

====================  ========================================================================
:mod:`.file`          the station file (YAML), read and written
:mod:`.world`         its simulated world: how the simulated camera differs from the scene
:mod:`.model`         its illuminations as lights of its scene, and its prediction
:mod:`.prediction`    the prediction of the station as built, a row an illumination
:mod:`.devices`       its camera and light controller opened by their backends
:mod:`.capture`       its capture: illuminations and darks into a capture folder
:mod:`.stopping`      sequential stopping: frames only until the classes are known
:mod:`.production`    a part located and measured on the running line
:mod:`.draft`         a first station file, drafted from devices and a scene
====================  ========================================================================

The names below are read from :mod:`.file` on first use: a module of this package (the
world's schema, which the simulated devices import while the station file's schema asks
the registry for them) must not pull in the station file's."""

__all__ = ["Illumination", "Station", "read_station", "station_hash", "write_station"]


def __getattr__(name: str):
    if name in __all__:
        from inspect_validate.station import file

        return getattr(file, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

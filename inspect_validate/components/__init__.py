"""Components of an inspection station: lights, optics and cameras."""

from inspect_validate.components.lights import (
    Light,
    blackbody,
    cie_daylight,
    cie_illuminant,
    led,
    phosphor_white_led,
    planck,
)
from inspect_validate.components.optics import (
    MATERIALS,
    Optics,
    ideal_lens,
    lens,
    material_transmission,
)
from inspect_validate.components.sensors import (
    BUILT_IN_CAMERAS,
    SensorModel,
    builtin_sensor,
    energy_efficiency,
)

__all__ = [
    "BUILT_IN_CAMERAS",
    "MATERIALS",
    "Light",
    "Optics",
    "SensorModel",
    "blackbody",
    "builtin_sensor",
    "cie_daylight",
    "cie_illuminant",
    "energy_efficiency",
    "ideal_lens",
    "led",
    "lens",
    "material_transmission",
    "phosphor_white_led",
    "planck",
]

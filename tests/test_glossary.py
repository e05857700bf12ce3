"""One word per concept (docs/development.md's glossary) in the public API's identifiers.

Every public module's ``__all__`` is walked: its functions and classes, their public
methods and every parameter. A word the glossary gives one meaning may not name
another concept there; each rule below is a word that did, and the word that
replaced it.
"""

import importlib
import inspect
import pkgutil

import pytest

import inspect_validate

# Checked by name: (qualified name, the word used now).
RETIRED = {
    "inspect_validate.verification.measured.Capture": "MeasuredCapture (a capture is the "
    "sequence and its folder)",
    "inspect_validate.station.model.StationModel.lights": "illumination_lights (a light is a "
    "source of the scene; an illumination a state of the station's channels)",
}


def _public_api():
    """(qualified name, object) of every public function, class and method, and
    (qualified name of a parameter, its annotation) of every parameter of them."""
    seen = set()
    for info in pkgutil.walk_packages(inspect_validate.__path__, "inspect_validate."):
        if info.name.endswith("__main__") or any(
            part.startswith("_") for part in info.name.split(".")
        ):
            continue
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", ()):
            obj = getattr(module, name, None)
            if obj is None or id(obj) in seen:
                continue
            seen.add(id(obj))
            where = f"{info.name}.{name}"
            yield where, obj
            members = (
                [(f"{where}.{m}", v) for m, v in vars(obj).items() if not m.startswith("_")]
                if inspect.isclass(obj)
                else []
            )
            for qualified, member in [(where, obj), *members]:
                if member is not obj:
                    yield qualified, member
                target = member.fget if isinstance(member, property) else member
                if not callable(target):
                    continue
                try:
                    signature = inspect.signature(target)
                except (TypeError, ValueError):
                    continue
                for parameter in signature.parameters.values():
                    yield f"{qualified}({parameter.name})", parameter.annotation


API = list(_public_api())


def test_the_public_api_was_found():
    names = {name for name, _ in API}
    assert "inspect_validate.verification.verify.verify_capture" in names
    assert len(names) > 500


def test_a_check_is_a_verdict():
    """``check`` names a check of the acceptance section (a verdict): functions that
    refused bad input were check_golden, check_outputs and interruption.check; they
    validate (validate_golden, validate_outputs) or stop (stop_if_requested)."""
    wrong = [
        name
        for name, obj in API
        if callable(obj)
        and not inspect.isclass(obj)
        and name.rsplit(".", 1)[-1].startswith("check")
        and "Check" not in str(inspect.signature(obj).return_annotation)
    ]
    assert wrong == []


def test_a_camera_is_the_device_and_a_sensor_the_model_of_one():
    """A parameter named ``camera`` holding a SensorModel (measure_capture's, and
    saturation_level's) is a ``sensor``."""
    wrong = [
        name
        for name, annotation in API
        if name.endswith("(camera)") and "SensorModel" in str(annotation)
    ]
    assert wrong == []


@pytest.mark.parametrize("name", sorted(RETIRED))
def test_a_retired_name_does_not_come_back(name):
    module, _, attribute = name.rpartition(".")
    try:
        owner = importlib.import_module(module)
    except ImportError:  # a class's attribute
        module, _, cls = module.rpartition(".")
        owner = getattr(importlib.import_module(module), cls)
    assert not hasattr(owner, attribute), f"{name}: write {RETIRED[name]}"

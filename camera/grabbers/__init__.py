"""Camera backends behind one interface (:class:`inspect_validate.camera.grabbers.base.Grabber`)."""

from inspect_validate.camera.grabbers.base import Grabber

__all__ = ["Grabber"]

"""Camera backends behind one interface (:class:`camera.grabbers.base.Grabber`)."""

from camera.grabbers.base import Grabber

__all__ = ["Grabber"]

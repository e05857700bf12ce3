"""On-line verification of a running station.

=======================  =====================================================================
:mod:`.loop`             ``watch``: capture, verify and chart cycle after cycle
:mod:`.session`          what a watch holds while it runs
:mod:`.drift`            the EWMA drift charts and their likely cause
:mod:`.feed`             the line's frames as its own program writes them
:mod:`.rig`              a watch of a station of several cameras
:mod:`.history`          the history database, and how it is read back
:mod:`.history_writer`   writing the history, one transaction a cycle
:mod:`.serve`            ``/status`` and ``/metrics`` over HTTP on localhost
=======================  =====================================================================
"""

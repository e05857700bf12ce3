"""Verification: a station's measurement against its prediction, calibrated and checked,
on the bench and on the running line.

==========================  ==================================================================
:mod:`.plan`                what a verification needs before any frame: regions, comparisons,
                            model, field, sharpness, golden file
:mod:`.measured`            a capture folder measured in the station's regions
:mod:`.calibration`         photon-transfer gain K, irradiance scales
:mod:`.agreement`           predicted against measured, per class and comparison
:mod:`.uncertainty`         standard errors of what is compared
:mod:`.dominance`           illuminations not worth capturing
:mod:`.checks`              one check: value, limit, unit, verdict
:mod:`.acceptance_checks`   the checks the ``acceptance:`` section asks for
:mod:`.golden`              the golden file ``train`` makes
:mod:`.golden_checks`       drift from the golden statistics
:mod:`.health_checks`       what the camera and its transport reported
:mod:`.sharpness_checks`    the lens's MTF50 against its f-number's
:mod:`.diagnosis`           the likely cause of a change, bench and line alike
:mod:`.results`             what a verification found, and its verdict
:mod:`.verdict`             the one shape of a verdict, bench, rig and line
:mod:`.verify`              capture or read, measure, predict, compare, check
:mod:`.rig`                 a station of several cameras, each verified as its own
:mod:`.parts`               a running line's parts located and measured
:mod:`.parts_golden`        the golden parts ``train --production`` makes
:mod:`.production`          the verdict on a batch of parts
==========================  ==================================================================
"""

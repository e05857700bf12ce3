"""Verification: a station's measurement against its prediction, calibrated and checked.

=============================  ===============================================
:mod:`.acceptance`             the ``calibration:`` and ``acceptance:`` sections
:mod:`.calibration`            photon-transfer gain K, irradiance scales
:mod:`.checks`                 one check: value, limit, unit, verdict
:mod:`.verify`                 capture or read, measure, predict, compare, check
=============================  ===============================================
"""

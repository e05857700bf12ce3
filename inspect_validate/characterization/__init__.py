"""Characterising the station's own camera (EMVA 1288 release 4.0, linear model).

=========================  ===========================================================
:mod:`.series`             the capture plan: the exposure (or LED level) series, the
                           dark pairs, the spatial stacks
:mod:`.analysis`           K, σ_d, saturation, linearity, dark current, DSNU, PRNU,
                           SNR, dynamic range, with standard errors
:mod:`.camera_file`        the measured camera as a file the station reads
:mod:`.descriptor`         the run as an emva1288 descriptor file
:mod:`.sharpness`          the slanted-edge MTF of lens and sensor (ISO 12233 e-SFR)
=========================  ===========================================================
"""

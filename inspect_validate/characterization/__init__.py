"""Characterising the station's own camera (EMVA 1288 release 4.0, linear model), and its
light field and lens sharpness from targets.

=========================  ===========================================================
:mod:`.series`             the capture plan: the exposure (or LED level) series, the
                           dark pairs, the spatial stacks
:mod:`.analysis`           K, σ_d, saturation, linearity, dark current, DSNU, PRNU,
                           SNR, dynamic range, with standard errors
:mod:`.descriptor`         the run as an emva1288 descriptor file
:mod:`.sharpness`          the slanted-edge MTF of lens and sensor (ISO 12233 e-SFR)
:mod:`.sharpness_file`     ``sharpness.json``: the edge MTF per illumination
:mod:`.field`              the light's field over the frame: a surface fitted to a flat
                           target, each region's share and spread, the parts' slopes
:mod:`.field_file`         ``field.json``: the field per illumination
:mod:`.targets`            the flat and edge targets' captures measured
=========================  ===========================================================
"""

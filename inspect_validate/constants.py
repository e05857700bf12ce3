"""Physical constants (SI, exact since the 2019 redefinition), and the one bound on
exposure that station files, scene files and the model share."""

H = 6.62607015e-34
"""Planck constant, J·s."""
C = 2.99792458e8
"""Speed of light in vacuum, m/s."""
K_B = 1.380649e-23
"""Boltzmann constant, J/K."""

LONGEST_EXPOSURE_S = 100.0
"""The longest exposure a camera is set to, s (``camera.exposure_us`` ≤ 10⁸): longer is
refused in station, scene and characterize-plan files, and a combination whose
automatic exposure would need longer is too dim to predict."""

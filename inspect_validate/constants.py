"""Physical constants (SI, exact since the 2019 redefinition)."""

H = 6.62607015e-34
"""Planck constant, J·s."""
C = 2.99792458e8
"""Speed of light in vacuum, m/s."""
K_B = 1.380649e-23
"""Boltzmann constant, J/K."""

"""Stage 2, the model: the distributed dynamical matrix and masses of eq:motion / eq:mm
(``dynmat``, its pair blocks from ``solver.contact_law``) and operators built from them
(``operators``: M^-1/2 D M^-1/2, omega_max, the first-order J).
"""

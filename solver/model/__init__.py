"""Stage 2, the model: the contact law eq:eij with its energy, forces and Hessian blocks
(``contact_law``), the distributed dynamical matrix and masses of eq:motion / eq:mm (``dynmat``),
and operators built from them (``operators``: M^-1/2 D M^-1/2, omega_max, the first-order J).
"""

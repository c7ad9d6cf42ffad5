"""Stage 5, analysis (numpy/scipy only, no PETSc): C(k, t) and S(k, omega) (``correlations``;
fig:auto, fig:spec), fits eq:damped, power laws and k_c (``fits``), the lattice model eq:omega_t(k),
eq:omega_r(k), eq:f(k), eq:g(k) and its band edges (``lattice``), a scene's dispersion analysis
(``dispersion``), and the paper's claims with their tolerances (``claims``).
"""

"""Stage 3, the spectrum: exact eigenvalues by SLEPc spectrum slicing and Sylvester inertias
(``slicing``), the exact vDOS from inertias at the bin edges (``counting``), the stochastic vDOS
(``kpm``), and per-mode K, Q, participation, the vDOS and
omega_c (``modes``; Fig. 1 fig:vdof, Fig. 6 fig:kene).
"""

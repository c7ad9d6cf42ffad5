"""Stage 4, standing waves (tab:modes, eq:initial): the excitation and allowed wave numbers
(``excitation``), the Fourier sampler (``sampling``), PETSc TS integrators and the time-step
policy (``integrators``), the exact Lanczos path (``spectral``), and one unit's datasets (``unit``).
"""

"""Stage 4, standing waves (tab:modes, eq:initial): the excitation and allowed wave numbers
(``excitation``), how the waves of a matrix run -- the method, time grid, TS schedule and
stability limit, decided once (``schedule``) --, the Fourier sampler (``sampling``), PETSc TS
integrators with problem objects that own their PETSc objects (``integrators``), the exact
Lanczos path (``spectral``), and one unit's datasets (``unit``).
"""

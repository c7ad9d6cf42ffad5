"""Stage 1, packings: periodic geometry and contact detection (``geometry``), the FIRE minimiser
(``fire``), the mechanics of a packing under its normal forces -- the force engine FIRE runs on,
rattlers, pressure and z, net forces and the equilibrium and rigidity checks (``mechanics``, its
compiled force pass in ``pair_forces``) --, the paper's bidisperse jammed packings (``jammed``),
and LAMMPS as the packing engine (``lammps_engine``).
"""

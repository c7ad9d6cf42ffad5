"""Energy transport by the vibrational modes: the Allen-Feldman diffusivity of each mode
(``allen_feldman``; docs/diffusivity.md).  A stage above spectrum and waves, below analysis."""

"""Energy transport by the vibrational modes: the Allen-Feldman diffusivity of each mode
(``allen_feldman``; docs/diffusivity.md) and its bin averages without eigenvectors by KPM
(``kpm_diffusivity``; docs/diffusivity_trace.md).  A stage above spectrum and waves, below analysis."""

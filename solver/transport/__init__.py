"""Energy transport by the vibrational modes: the Allen-Feldman diffusivity of each mode
(``allen_feldman``; docs/diffusivity.md), its bin averages without eigenvectors by KPM
(``kpm_diffusivity``; docs/diffusivity_trace.md), and the diffusivity measured directly as a
spreading energy packet (``packet``; docs/diffusivity_packet.md).  A stage above spectrum and
waves, below analysis."""

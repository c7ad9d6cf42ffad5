"""Stage 1, packings: periodic geometry and contacts (``geometry``), the FIRE minimiser
(``fire``), and the paper's bidisperse jammed packings with rattlers (``jammed``).
"""

# modes.energies swaps K_x and K_y (K, Q and the normalisation unchanged)
from solver.spectrum import modes
orig = modes.energies
def energies(sums, n_disks):
    e = orig(sums, n_disks)
    e["Kx"], e["Ky"] = e["Ky"], e["Kx"]
    return e
modes.energies = energies

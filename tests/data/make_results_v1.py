"""Make tests/data/results_v1.h5: a tiny results file of format_version 1, written by rotsound itself.

It is kept as written, so that tests/io/test_results_format.py checks that every later rotsound still
reads a version-1 file (the manual, docs/results_file.md, promises that results files written before stay readable).
Rerun only when the format_version changes, to add a file for the new version beside this one:

    cd /work/main && .venv/bin/python tests/data/make_results_v1.py

The scene (16 disks, rho = 0 and 1, full spectrum with K and Q, spectral L and RT waves at n = 1, 2,
with their fits) is below; the file also holds it, as the root attribute ``scene``.
"""

import pathlib
import shutil
import subprocess
import sys
import tempfile

import h5py

HERE = pathlib.Path(__file__).resolve().parent
SCENE = """\
output: {out}
cache: off
seed: 1
packing: {{n: 16, phi: 0.9, count: 1}}
model: {{rho: [0.0, 1.0]}}
spectrum: {{energies: true}}
waves: {{modes: [L, RT], n: [1, 2], method: spectral, t_end: 10.0, dt: 0.1, sample_every: 2}}
"""


def main() -> None:
    with tempfile.TemporaryDirectory() as folder:
        out = pathlib.Path(folder) / "results_v1.h5"
        scene = pathlib.Path(folder) / "scene.yaml"
        scene.write_text(SCENE.format(out=out))
        subprocess.run([sys.executable, "-m", "solver", "run", str(scene)], check=True, cwd=HERE.parents[1])
        with h5py.File(out, "r") as f:
            if int(f.attrs["format_version"]) != 1:
                sys.exit(f"this rotsound writes format_version {int(f.attrs['format_version'])}, not 1: "
                         f"keep results_v1.h5 and write a script for the new version")
        shutil.copyfile(out, HERE / "results_v1.h5")
    print(f"wrote {HERE / 'results_v1.h5'}")


if __name__ == "__main__":
    main()

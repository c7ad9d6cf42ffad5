#!/bin/bash
# Example batch job for the paper's programme (configs/paper.yaml) on a Slurm cluster.
# Adapt the partition, the node count and how your site provides Debian's PETSc/SLEPc stack
# (here: the same Debian 12 image with `make setup` done once in this checkout).
# 64 ranks in groups of 2 (GROUP_SIZE): 32 (rho, packing) units are solved at a time, each on 2
# ranks. Use 1 when the units are many and small (N = 2048 spectra or counts), more when one unit
# needs more memory or time than one rank has (N = 32768 slicing); it must divide the rank count.
#SBATCH --job-name=rotsound-paper
#SBATCH --nodes=1
#SBATCH --ntasks=64
#SBATCH --mem=128G
#SBATCH --time=08:00:00
#SBATCH --requeue                 # a preempted job starts again...
#SBATCH --signal=B:TERM@300       # ...and SIGTERM five minutes before the end lets the unit in flight finish
#SBATCH --output=results/paper_%j.log
set -euo pipefail
cd "${SLURM_SUBMIT_DIR:-$(dirname "$0")/../..}"
mkdir -p results
# Finished units are kept in results/*.units/: a requeued or resubmitted job resumes from them.
# rotsound exits 143 after a SIGTERM; resubmit the same script to continue.
# A resubmitted job may use another rank count or group size: units are keyed by content.
mpirun -n "${SLURM_NTASKS:-2}" .venv/bin/rotsound run configs/paper.yaml --group-size "${GROUP_SIZE:-2}" &
pid=$!
# SIGTERM goes to the ranks (mpirun's children on this node), not to mpirun: Open MPI's mpirun
# answers a SIGTERM by tearing the job down. One node here; across nodes launch with srun
# instead of mpirun, so that Slurm's --signal reaches every rank itself.
trap 'pkill -TERM -P "$pid"' TERM
status=0
wait "$pid" || status=$?         # returns early when the trap fires...
if kill -0 "$pid" 2>/dev/null; then
    status=0; wait "$pid" || status=$?   # ...so wait for the unit in flight to finish
fi
[ "$status" -eq 0 ] || exit "$status"
.venv/bin/rotsound report configs/paper.yaml --output REPRODUCTION_paper.md

# The YADE half of scripts/crosschecks/crosscheck_yade.py, run by YADE's launcher, never imported:
#     yade -n -x scripts/crosschecks/yade_referee.py prepare FOLDER N SEED RHO
#     yade -n -x scripts/crosschecks/yade_referee.py waves FOLDER DT STEPS EVERY
#     yade -n -x scripts/crosschecks/yade_referee.py forces FOLDER
# prepare: a stressed frictional periodic 3D packing made by YADE (FrictMat, ScGeom,
#   Law2_ScGeom_FrictPhys_CundallStrack), in units where rotsound's are YADE's: every sphere a
#   FrictMat of its own with young = 1 / R, so that every contact has kn = 1; ks = RHO kn
#   (FrictMat's poisson); density such that the mean mass is 1; friction angle atan(1e4), so that
#   no contact slides. makeCloud (radii 0.4 to 0.6, rRelFuzz 0.2) in a periodic cube,
#   PeriIsoCompressor to a mean stress of 0.04 kn/d0 (overlaps about 0.6 % of a diameter), then
#   damped dynamics (NewtonIntegrator damping 0.4) in the fixed cell until YADE's unbalanced force
#   is below 1e-10. Writes FOLDER/state.yade.gz (O.save: the scene with its interactions and their
#   shear forces), FOLDER/packing.spheres and FOLDER/packing.contacts (the layouts of
#   tests/data/dem/yade_3d_friction.py) and FOLDER/prepare.json (what it reached).
# waves: from FOLDER/state.yade.gz, undamped, at O.dt = DT, for each start in FOLDER/starts.npy
#   (R, N, 6): velocity and angular velocity of every body, YADE units) a run of STEPS steps,
#   sampling every EVERY steps (t = 0 first); writes FOLDER/samples.npy (R, S, N, 6). YADE's
#   leapfrog keeps velocities at half steps: the sample after step n is v((n - 1/2) dt).
# forces: from the saved scene, for each displacement in FOLDER/moves.npy ((R, N, 6): translation
#   and rotation of every body), one step at dt = 1e-3 with the bodies moved by it and given the
#   velocity move / dt (so that YADE's shear increment is the move: it integrates velocities) and
#   one with minus it; writes the half difference of the forces and torques YADE computes,
#   FOLDER/forces.npy (R, N, 6): minus the stiffness applied to the move.
import json
import math
import os
import sys

import numpy as np
from yade import pack

MODE, FOLDER = sys.argv[1], sys.argv[2]


def write_files():
    size = O.cell.size
    inters = [i for i in O.interactions if i.isReal]
    with open(os.path.join(FOLDER, 'packing.contacts'), 'w') as out:
        out.write('# YADE %s, written by scripts/crosschecks/yade_referee.py: id1 id2 shearForce normalForce\n' % version)
        for i in inters:
            fs, fn = i.phys.shearForce, i.phys.normalForce
            out.write('%d %d %.17g %.17g %.17g %.17g %.17g %.17g\n'
                      % (i.id1, i.id2, fs[0], fs[1], fs[2], fn[0], fn[1], fn[2]))
    with open(os.path.join(FOLDER, 'packing.spheres'), 'w') as out:
        out.write('##PERIODIC:: %.17g %.17g %.17g\n' % (size[0], size[1], size[2]))
        for b in O.bodies:
            p = O.cell.wrap(b.state.pos)
            out.write('%.17g %.17g %.17g %.17g -1\n' % (p[0], p[1], p[2], b.shape.radius))
    return len(inters)


def prepare(n, seed, rho):
    side = 8.0 * (n / 128.0) ** (1.0 / 3.0)
    O.periodic = True
    O.cell.setBox(side, side, side)
    cloud = pack.SpherePack()
    cloud.makeCloud((0, 0, 0), (side, side, side), rMean=0.5, rRelFuzz=0.2, num=n, periodic=True, seed=seed)
    volume = np.mean([4.0 / 3.0 * math.pi * r ** 3 for _, r in cloud])
    friction = math.atan(1e4)
    O.materials.append(FrictMat(young=1.0, poisson=rho, frictionAngle=friction, density=1.0 / volume))
    cloud.toSimulation()  # masses and inertias from this material's density
    for b in O.bodies:
        b.mat = FrictMat(young=1.0 / b.shape.radius, poisson=rho, frictionAngle=friction, density=1.0 / volume)

    def compressed():
        O.engines[3].dead = True
        O.cell.velGrad = Matrix3.Zero
        settle.dead = False

    def settled():
        if utils.unbalancedForce() > 1e-10:
            return
        O.pause()

    O.engines = [
        ForceResetter(),
        InsertionSortCollider([Bo1_Sphere_Aabb()]),
        InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                        [Law2_ScGeom_FrictPhys_CundallStrack()]),
        PeriIsoCompressor(charLen=1.0, stresses=[-0.04], maxUnbalanced=1e-4, keepProportions=True,
                          doneHook='compressed()'),
        PyRunner(command='settled()', iterPeriod=500, dead=True, label='settle'),
        NewtonIntegrator(damping=0.4, label='newton'),
    ]
    globals().update(compressed=compressed, settled=settled)
    O.dt = 0.5 * PWaveTimeStep()
    O.run(20000000, True)
    O.save(os.path.join(FOLDER, 'state.yade.gz'))
    contacts = write_files()
    report = {'version': version, 'n': len(O.bodies), 'step': O.iter, 'contacts': contacts,
              'unbalanced': utils.unbalancedForce(),
              'max_force': max(O.forces.f(b.id).norm() for b in O.bodies),
              'max_torque': max(O.forces.t(b.id).norm() for b in O.bodies),
              'mean_stress': -utils.getStress().trace() / 3.0}
    with open(os.path.join(FOLDER, 'prepare.json'), 'w') as out:
        json.dump(report, out)


def rest_scene():
    """The saved scene, its compressor and runners off, undamped."""
    O.load(os.path.join(FOLDER, 'state.yade.gz'))
    for engine in O.engines:
        if isinstance(engine, (PyRunner, PeriIsoCompressor)):
            engine.dead = True
        if isinstance(engine, NewtonIntegrator):
            engine.damping = 0.0


def waves(dt, steps, every):
    rest_scene()
    O.dt = dt
    O.saveTmp('rest')
    starts = np.load(os.path.join(FOLDER, 'starts.npy'))
    out = np.empty((starts.shape[0], steps // every + 1) + starts.shape[1:])
    for r, start in enumerate(starts):
        O.loadTmp('rest')
        for b in O.bodies:
            b.state.vel = Vector3(*start[b.id, :3])
            b.state.angVel = Vector3(*start[b.id, 3:])
        for s in range(out.shape[1]):
            if s:
                O.run(every, True)
            for b in O.bodies:
                out[r, s, b.id, :3] = tuple(b.state.vel)
                out[r, s, b.id, 3:] = tuple(b.state.angVel)
    np.save(os.path.join(FOLDER, 'samples.npy'), out)


def forces():
    rest_scene()
    O.dt = 1e-3
    O.saveTmp('rest')
    moves = np.load(os.path.join(FOLDER, 'moves.npy'))
    out = np.zeros_like(moves)
    for r, move in enumerate(moves):
        for sign in (1.0, -1.0):
            O.loadTmp('rest')
            for b in O.bodies:
                d = sign * move[b.id]
                b.state.pos = b.state.pos + Vector3(*d[:3])
                b.state.vel = Vector3(*(d[:3] / O.dt))
                b.state.angVel = Vector3(*(d[3:] / O.dt))
            O.run(1, True)
            for b in O.bodies:
                out[r, b.id] += 0.5 * sign * np.array(tuple(O.forces.f(b.id)) + tuple(O.forces.t(b.id)))
    np.save(os.path.join(FOLDER, 'forces.npy'), out)


if MODE == 'prepare':
    prepare(int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]))
elif MODE == 'waves':
    waves(float(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]))
else:
    forces()
sys.exit(0)

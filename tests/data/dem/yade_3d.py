# rotsound test data: a frictionless periodic 3D sphere packing made by YADE, written with
# YADE's two text exports.
# Remake (from this directory): yade -n -x yade_3d.py
# Writes yade_3d.txt (yade.export.textExt, format x_y_z_r) and yade_3d.spheres
# (SpherePack.save, whose first line '##PERIODIC:: Lx Ly Lz' records the periodic cell).
# N = 128 spheres, radii spread evenly over [0.4, 0.6] by makeCloud's rRelFuzz = 0.2 (mean
# diameter 1), density 2600, Young's modulus 1e5, friction angle 0. makeCloud scatters them in
# a periodic cell of 9 x 8 x 7;
# PeriIsoCompressor shrinks the cell (keeping its proportions) until the mean stress is 2000;
# then, in the fixed cell, damped dynamics run until YADE's unbalanced force (mean resultant
# over mean contact force) is below 1e-6, and positions are wrapped into the cell for export.
import sys
from yade import pack, export

O.periodic = True
O.cell.setBox(9.0, 8.0, 7.0)
O.materials.append(FrictMat(young=1e5, poisson=0.5, frictionAngle=0.0, density=2600.0))
cloud = pack.SpherePack()
cloud.makeCloud((0, 0, 0), (9.0, 8.0, 7.0), rMean=0.5, rRelFuzz=0.2, num=128, periodic=True,
                seed=20240519)
cloud.toSimulation()


def compressed():
    O.engines[3].dead = True
    O.cell.velGrad = Matrix3.Zero
    settle.dead = False


def settled():
    if utils.unbalancedForce() > 1e-6:
        return
    for b in O.bodies:
        b.state.pos = O.cell.wrap(b.state.pos)
    size = O.cell.size
    cell = '##PERIODIC:: %r %r %r' % (size[0], size[1], size[2])
    export.textExt('yade_3d.txt', format='x_y_z_r',
                   comment='periodic cell from (0, 0, 0) to (Lx, Ly, Lz):\n' + cell)
    spheres = pack.SpherePack()
    spheres.fromSimulation()
    spheres.save('yade_3d.spheres')
    print('YADE', version, 'N', len(O.bodies), 'cell', tuple(size),
          'unbalanced', utils.unbalancedForce(),
          'mean stress', utils.getStress().trace() / 3)
    O.pause()


O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                    [Law2_ScGeom_FrictPhys_CundallStrack()]),
    PeriIsoCompressor(charLen=1.0, stresses=[-2000.0], maxUnbalanced=1e-4, keepProportions=True,
                      doneHook='compressed()'),
    NewtonIntegrator(damping=0.4),
    PyRunner(command='settled()', iterPeriod=1000, dead=True, label='settle'),
]
O.dt = 0.5 * PWaveTimeStep()
O.run(5000000, True)
sys.exit(0)

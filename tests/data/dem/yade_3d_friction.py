# rotsound test data: a frictional periodic 3D sphere packing made by YADE, at rest on its shear
# forces, with its contact file.
# Remake (from this directory): yade -n -x yade_3d_friction.py, and
# yade -n -x yade_3d_friction.py uniform for the packing with one normal stiffness (below).
# Writes yade_3d_friction.spheres (SpherePack.save's format: '##PERIODIC:: Lx Ly Lz', then
# 'x y z r -1' per sphere, line k+2 being body id k; written here with %.17g, since
# SpherePack.save prints six significant digits) and yade_3d_friction.contacts (one line per real
# interaction: id1 id2, i.phys.shearForce, i.phys.normalForce; see its header).
# N = 128 spheres, radii spread evenly over [0.4, 0.6] by makeCloud's rRelFuzz = 0.2 (mean
# diameter 1), density 2600, FrictMat young = 1e5 (Ip2_FrictMat_FrictMat_FrictPhys:
# kn = 2 E R1 R2 / (R1 + R2)), poisson = 2/7 (in YADE the ratio ks/kn, not Poisson's ratio),
# friction angle atan(0.5) (Law2_ScGeom_FrictPhys_CundallStrack: |shearForce| <= 0.5 |normalForce|).
# makeCloud scatters the spheres in a periodic cell of 8 x 8 x 8; PeriIsoCompressor shrinks it
# (keeping its proportions) to a mean stress of 2000, friction on throughout; then, in the fixed
# cell, damped dynamics (NewtonIntegrator's local damping 0.4) run until YADE's unbalanced force
# is below 1e-9, and the files are written from that state (positions wrapped into the cell).
# With the argument 'uniform' every sphere gets a material of its own, young = 1e5 * 0.5 / R, so that
# E1 R1 = E2 R2 and every contact has the same kn = 2 E1 R1 E2 R2 / (E1 R1 + E2 R2) = 5e4 (rotsound's
# harmonic law: one kn); the files are then yade_3d_friction_uniform.spheres and .contacts, and
# yade_3d_friction_uniform.response: YADE's one-step Jacobian applied to two random moves (see
# respond() below).
import math
import sys
from yade import pack

UNIFORM = sys.argv[1:] == ['uniform']
NAME = 'yade_3d_friction_uniform' if UNIFORM else 'yade_3d_friction'


def material(young):
    return FrictMat(young=young, poisson=2.0 / 7.0, frictionAngle=math.atan(0.5), density=2600.0)


O.periodic = True
O.cell.setBox(8.0, 8.0, 8.0)
O.materials.append(material(1e5))
cloud = pack.SpherePack()
cloud.makeCloud((0, 0, 0), (8.0, 8.0, 8.0), rMean=0.5, rRelFuzz=0.2, num=128, periodic=True,
                seed=20240607)
cloud.toSimulation()
if UNIFORM:
    for b in O.bodies:
        b.mat = material(1e5 * 0.5 / b.shape.radius)

HEADER = """# YADE %s: frictional periodic packing %s.spheres, N = %d, at step %d
# periodic cell from (0, 0, 0) to (Lx, Ly, Lz):
##PERIODIC:: %r %r %r
# One line per real interaction (Law2_ScGeom_FrictPhys_CundallStrack), %d lines.
# columns: id1 id2 fsx fsy fsz fnx fny fnz
#   id1 id2          i.id1, i.id2: body ids = 0-based line numbers in %s.spheres
#   fsx fsy fsz      i.phys.shearForce
#   fnx fny fnz      i.phys.normalForce = kn * i.geom.penetrationDepth * i.geom.normal
# Sign convention: i.geom.normal points from id1 to id2 (across the periodic boundary where the
# pair is), and normalForce + shearForce is the force on id2 from id1; the force on id1 is
# -(normalForce + shearForce). Torques (YADE's, about the centres): on id1
# (R1 - depth/2) normal x (-(normalForce + shearForce)), on id2 (R2 - depth/2) normal x
# (-(normalForce + shearForce)): the lever is the distance to the middle of the overlap.
"""


def compressed():
    O.engines[3].dead = True
    O.cell.velGrad = Matrix3.Zero
    settle.dead = False


def settled():
    if utils.unbalancedForce() > 1e-9:
        return
    O.pause()
    inters = [i for i in O.interactions if i.isReal]
    size = O.cell.size
    with open(NAME + '.contacts', 'w') as out:
        out.write(HEADER % (version, NAME, len(O.bodies), O.iter, size[0], size[1], size[2], len(inters), NAME))
        for i in inters:
            fs, fn = i.phys.shearForce, i.phys.normalForce
            out.write('%d %d %.17g %.17g %.17g %.17g %.17g %.17g\n'
                      % (i.id1, i.id2, fs[0], fs[1], fs[2], fn[0], fn[1], fn[2]))
    fmax = max(O.forces.f(b.id).norm() for b in O.bodies)
    tmax = max(O.forces.t(b.id).norm() for b in O.bodies)
    with open(NAME + '.spheres', 'w') as out:
        out.write('##PERIODIC:: %.17g %.17g %.17g\n' % (size[0], size[1], size[2]))
        for b in O.bodies:
            p = O.cell.wrap(b.state.pos)
            out.write('%.17g %.17g %.17g %.17g -1\n' % (p[0], p[1], p[2], b.shape.radius))
    print('YADE', version, 'N', len(O.bodies), 'step', O.iter, 'cell', tuple(size),
          'contacts', len(inters), 'unbalanced', utils.unbalancedForce(),
          'max |O.forces.f|', fmax, 'max |O.forces.t|', tmax,
          'mean stress', utils.getStress().trace() / 3)


O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()]),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                    [Law2_ScGeom_FrictPhys_CundallStrack()]),
    PeriIsoCompressor(charLen=1.0, stresses=[-2000.0], maxUnbalanced=1e-4, keepProportions=True,
                      doneHook='compressed()'),
    # before the integrator: the files get the positions on which this step's forces were computed
    PyRunner(command='settled()', iterPeriod=1000, dead=True, label='settle'),
    NewtonIntegrator(damping=0.4),
]
RESPONSE_HEADER = """# YADE %s: one-step responses of the packing %s.spheres at rest (as written).
# For each of 2 moves x (numpy default_rng(%d).normal, times 1e-7, every body; a move is the
# translation and the rotation of each body), one step at dt = 1e-3, undamped, with every body
# moved by +x and given the velocity x / dt (YADE's shear increment integrates velocities), and one
# with -x; the forces and torques YADE computes in that step (O.forces), half their difference:
# minus YADE's stiffness applied to x, to second order in x.
# columns: move body dx dy dz rx ry rz fx fy fz tx ty tz
"""


def respond(seed=7):
    """Write NAME.response (RESPONSE_HEADER) from the state at rest."""
    import numpy as np

    for engine in O.engines:
        if isinstance(engine, NewtonIntegrator):
            engine.damping = 0.0
    settle.dead = True
    O.dt = 1e-3
    O.saveTmp('rest')
    moves = 1e-7 * np.random.default_rng(seed).normal(size=(2, len(O.bodies), 6))
    with open(NAME + '.response', 'w') as out:
        out.write(RESPONSE_HEADER % (version, NAME, seed))
        for r, move in enumerate(moves):
            half = np.zeros((len(O.bodies), 6))
            for sign in (1.0, -1.0):
                O.loadTmp('rest')
                for b in O.bodies:
                    d = sign * move[b.id]
                    b.state.pos = b.state.pos + Vector3(*d[:3])
                    b.state.vel = Vector3(*(d[:3] / O.dt))
                    b.state.angVel = Vector3(*(d[3:] / O.dt))
                O.run(1, True)
                for b in O.bodies:
                    half[b.id] += 0.5 * sign * np.array(tuple(O.forces.f(b.id)) + tuple(O.forces.t(b.id)))
            for k in range(len(O.bodies)):
                out.write('%d %d ' % (r, k) + ' '.join('%.17g' % v for v in np.r_[move[k], half[k]]) + '\n')


O.dt = 0.5 * PWaveTimeStep()
O.run(5000000, True)
if UNIFORM:
    respond()
sys.exit(0)

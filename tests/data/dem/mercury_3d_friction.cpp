// A frictional periodic 3D packing at rest, made by MercuryDPM (tests/data/dem/README.md says how
// MercuryDPM was built and this driver compiled and run).  Writes mercury_3d_friction.data,
// .fstat and .restart, once, at the end.
//
// N = 200 spheres, 100 of final radius 0.4 and 100 of 0.6 (mean diameter 1), density 6/pi (a sphere
// of diameter 1 has mass 1), in a periodic cube sized for packing fraction PHI.  Species
// LinearViscoelasticSlidingFrictionSpecies: normal spring k = 1 (force k * overlap) with dissipation
// GAMMA_N, tangential spring kt = 2/7 with dissipation GAMMA_T, Coulomb friction MU; no rolling or
// torsion, no gravity, no walls.  The spheres start at random (no overlap) at 0.6 of their final
// radii and grow at a constant rate to them in GROW time units, with a background drag DRAG; then
// the packing is held until every force and torque component is below REST_TOL and every velocity
// component below REST_TOL / DRAG (so the drag is below REST_TOL too), and the files are written.
// Deterministic: one process, a fixed seed.
#include <Mercury3D.h>
#include <Boundaries/PeriodicBoundary.h>
#include <Particles/SphericalParticle.h>
#include <Species/LinearViscoelasticSlidingFrictionSpecies.h>

#include <cmath>
#include <random>
#include <vector>

namespace {
const unsigned N = 200;
const double PHI = 0.62;          // final packing fraction
const double START = 0.6;         // radii at the start, relative to the final ones
const double DT = 0.02;           // time step (a sphere of diameter 0.8: contact time ~1.6)
const double GROW = 400.0;        // time to grow to the final radii
const double HOLD_MAX = 40000.0;  // longest hold after growing
const double DRAG = 0.05;         // background drag (force -DRAG v)
const double GAMMA_N = 0.5, GAMMA_T = 0.25, KT = 2.0 / 7.0, MU = 0.5;
const double REST_TOL = 1e-13;    // at rest: every force and torque component below this
const unsigned SEED = 5801;
}

class FrictionalPacking : public Mercury3D
{
public:
    void setupInitialConditions() override
    {
        setSystemDimensions(3);
        setParticleDimensions(3);
        setGravity(Vec3D(0.0, 0.0, 0.0));
        setBackgroundDrag(DRAG);
        setTimeStep(DT);
        setTimeMax(GROW + HOLD_MAX);

        LinearViscoelasticSlidingFrictionSpecies species;
        species.setDensity(6.0 / constants::pi);
        species.setStiffness(1.0);
        species.setDissipation(GAMMA_N);
        species.setSlidingStiffness(KT);
        species.setSlidingDissipation(GAMMA_T);
        species.setSlidingFrictionCoefficient(MU);
        auto* s = speciesHandler.copyAndAddObject(species);

        double solid = 0.0;
        for (unsigned i = 0; i < N; ++i)
        {
            radius_.push_back(i % 2 ? 0.6 : 0.4);
            solid += 4.0 / 3.0 * constants::pi * std::pow(radius_.back(), 3);
        }
        const double side = std::cbrt(solid / PHI);
        setDomain(Vec3D(0.0, 0.0, 0.0), Vec3D(side, side, side));
        PeriodicBoundary boundary;
        for (const Vec3D& normal : {Vec3D(1, 0, 0), Vec3D(0, 1, 0), Vec3D(0, 0, 1)})
        {
            boundary.set(normal, 0.0, side);
            boundaryHandler.copyAndAddObject(boundary);
        }

        std::mt19937 rng(SEED);
        std::uniform_real_distribution<double> uniform(0.0, side);
        std::vector<Vec3D> placed;
        for (unsigned i = 0; i < N; ++i)
        {
            Vec3D x;
            bool free;
            do
            {
                x = Vec3D(uniform(rng), uniform(rng), uniform(rng));
                free = true;
                for (unsigned j = 0; j < placed.size() && free; ++j)
                {
                    Vec3D d = x - placed[j];
                    d.X -= side * std::round(d.X / side);
                    d.Y -= side * std::round(d.Y / side);
                    d.Z -= side * std::round(d.Z / side);
                    free = d.getLength() > START * (radius_[i] + radius_[j]);
                }
            } while (!free);
            placed.push_back(x);
            SphericalParticle p;
            p.setSpecies(s);
            p.setRadius(START * radius_[i]);
            p.setPosition(x);
            p.setVelocity(Vec3D(0.0, 0.0, 0.0));
            particleHandler.copyAndAddObject(p);
        }
    }

    void actionsAfterTimeStep() override
    {
        if (getTime() < GROW)
        {
            const double scale = START + (1.0 - START) * std::min(1.0, (getTime() + getTimeStep()) / GROW);
            for (unsigned i = 0; i < N; ++i)
                particleHandler.getObject(i)->setRadius(scale * radius_[i]);
            hGridRebuild();  // the grid's cells follow the growing radii
            return;
        }
        double largest = 0.0, fastest = 0.0;
        for (BaseParticle* p : particleHandler)
        {
            const Vec3D f = p->getForce(), t = p->getTorque(), v = p->getVelocity();
            for (double c : {f.X, f.Y, f.Z, t.X, t.Y, t.Z})
                largest = std::max(largest, std::fabs(c));
            for (double c : {v.X, v.Y, v.Z})
                fastest = std::max(fastest, std::fabs(c));
        }
        if (getNumberOfTimeSteps() % 10000 == 0)
            logger(INFO, "t = %: largest force or torque component %, velocity component %", getTime(), largest,
                   fastest);
        if (largest < REST_TOL && fastest * DRAG < REST_TOL)
        {
            logger(INFO, "at rest at t = % (step %): largest force or torque component %, velocity component %",
                   getTime(), getNumberOfTimeSteps(), largest, fastest);
            for (File* file : {&dataFile, &fStatFile, &restartFile})
                file->setFileType(FileType::ONE_FILE);  // the final state only: written by solve() on return
            discontinueSolve();
        }
    }

private:
    std::vector<double> radius_;
};

int main()
{
    FrictionalPacking packing;
    packing.setName("mercury_3d_friction");
    packing.setFileType(FileType::NO_FILE);
    packing.setSaveCount(10000);  // MercuryDPM prints the time at every save
    packing.dataFile.getFstream().precision(17);   // radii, velocities and the box; positions get 15 digits
    packing.fStatFile.getFstream().precision(17);
    packing.restartFile.getFstream().precision(17);
    packing.solve();
    return 0;
}

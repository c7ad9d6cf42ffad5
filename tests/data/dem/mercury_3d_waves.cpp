// MercuryDPM's own small-amplitude dynamics about its frictional packing at rest
// (tests/data/dem/README.md; the referee of tests/io/test_mercury.py).  One process per run:
//
//     mercury_3d_waves START SIGN OUT DT SAMPLE_STEPS T_END
//
// reads mercury_3d_friction.restart (the packing at rest with its contacts and their tangential
// springs), switches every dissipation (normal, sliding, background drag) off, raises the Coulomb
// coefficient from 0.5 to MU_WAVES (so that the contacts the packing left at the Coulomb limit stick:
// small-amplitude dynamics without sliding, rotsound's model.mobilised: stick), gives particle i
// SIGN times the velocity and angular velocity of line i + 1 of the file START ("vx vy vz wx wy wz",
// MercuryDPM's units), and integrates (MercuryDPM's velocity Verlet, time step DT) to T_END, writing
// OUT.data (MercuryDPM's .data, 17 digits) at t = 0 and every SAMPLE_STEPS steps.
//
// The start velocities are given after MercuryDPM's first force evaluation (initialiseSolve), which
// it makes with every particle at rest: every force evaluation integrates each sliding spring by dt
// times the pair's relative velocity, so the first one, with the start velocities, would shift
// every spring by v(0) dt (measured: the result then converges only as dt to rotsound's).
#include <Mercury3D.h>
#include <Species/LinearViscoelasticSlidingFrictionSpecies.h>

#include <fstream>
#include <string>

const double MU_WAVES = 10.0;

class Waves : public Mercury3D
{
public:
    Waves(const std::string& start, double sign) : start_(start), sign_(sign) {}

    void setupInitialConditions() override
    {
        auto* species = dynamic_cast<LinearViscoelasticSlidingFrictionSpecies*>(speciesHandler.getObject(0));
        logger.assert_always(species != nullptr && speciesHandler.getSize() == 1, "one sliding-friction species");
        species->setDissipation(0.0);
        species->setSlidingDissipation(0.0);
        species->setSlidingFrictionCoefficient(MU_WAVES);
        setBackgroundDrag(0.0);
        for (BaseParticle* p : particleHandler)
        {
            p->setVelocity(Vec3D(0.0, 0.0, 0.0));
            p->setAngularVelocity(Vec3D(0.0, 0.0, 0.0));
        }
    }

    void start()
    {
        std::ifstream in(start_);
        for (BaseParticle* p : particleHandler)
        {
            Vec3D v, w;
            in >> v >> w;
            logger.assert_always(static_cast<bool>(in), "START holds fewer than % lines", particleHandler.getSize());
            p->setVelocity(sign_ * v);
            p->setAngularVelocity(sign_ * w);
        }
    }

private:
    std::string start_;
    double sign_;
};

int main(int argc, char* argv[])
{
    logger.assert_always(argc == 7, "usage: mercury_3d_waves START SIGN OUT DT SAMPLE_STEPS T_END");
    Waves waves(argv[1], std::stod(argv[2]));
    waves.setName("mercury_3d_friction");
    waves.readRestartFile();
    waves.setRestarted(false);  // a new run from the restart's state: time 0, setupInitialConditions above
    waves.setName(argv[3]);
    waves.setTimeStep(std::stod(argv[4]));
    waves.setSaveCount(std::stoul(argv[5]));
    waves.setTimeMax(std::stod(argv[6]));
    waves.setFileType(FileType::NO_FILE);
    waves.dataFile.setFileType(FileType::ONE_FILE);
    waves.dataFile.getFstream().precision(17);
    waves.initialiseSolve();
    waves.start();
    while (waves.getTime() < waves.getTimeMax())
        waves.computeOneTimeStep();
    waves.finaliseSolve();
    return 0;
}

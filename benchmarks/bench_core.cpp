// Micro-benchmarks of the costs that dominate planning (docs/design.md 8): FK, Jacobian, IK, isValid.
// Prints median and p90 per call with the CPU named. Not a test: `make bench` runs it.
#include "slideplan/collision.hpp"
#include "slideplan/contact_frame.hpp"
#include "slideplan/mesh.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

using namespace slideplan;

namespace
{
    std::string cpuName()
    {
        std::ifstream cpuinfo("/proc/cpuinfo");
        for (std::string line; std::getline(cpuinfo, line);)
            if (line.rfind("model name", 0) == 0)
                return line.substr(line.find(':') + 2);
        return "unknown CPU";
    }

    /// Times `batches` batches of `perBatch` calls; reports per-call median and p90 in microseconds.
    void report(const char *name, int batches, int perBatch, const std::function<void(int)> &call)
    {
        std::vector<double> perCall;
        int counter = 0;
        for (int b = 0; b < batches; ++b)
        {
            const auto start = std::chrono::steady_clock::now();
            for (int i = 0; i < perBatch; ++i)
                call(counter++);
            const std::chrono::duration<double, std::micro> elapsed = std::chrono::steady_clock::now() - start;
            perCall.push_back(elapsed.count() / perBatch);
        }
        std::sort(perCall.begin(), perCall.end());
        std::printf("%-28s median %9.2f us   p90 %9.2f us\n", name, perCall[perCall.size() / 2],
                    perCall[perCall.size() * 9 / 10]);
    }
}  // namespace

int main(int argc, char **argv)
{
    std::printf("slideplan core micro-benchmarks on %s\n", cpuName().c_str());
    Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
    mount.translation().z() = 0.20;
    const auto robot = std::make_shared<RobotModel>(
        RobotModel::fromFile(std::string(SLIDEPLAN_DATA_DIR) + "/robots/wam_t42.urdf", "fingertip_contact", mount));
    Polygon2 square(4, 2);
    square << 0.30, -0.20, 0.70, -0.20, 0.70, 0.20, 0.30, 0.20;
    CollisionWorld world(robot, SupportSurface(square, 0.0), {}, {"t42_finger1_proximal", "t42_finger1_distal"});

    std::mt19937_64 rng(1);
    std::vector<Eigen::VectorXd> configurations;
    std::vector<Eigen::Isometry3d> targets;
    for (int i = 0; i < 2000; ++i)
    {
        configurations.push_back(robot->randomConfiguration(rng));
        targets.push_back(robot->fk(configurations.back()));
    }
    const auto pick = [&](int i) -> const Eigen::VectorXd & { return configurations[i % configurations.size()]; };
    volatile double sink = 0.0;

    report("fk", 50, 2000, [&](int i) { sink = sink + robot->fk(pick(i)).translation().x(); });
    report("jacobian", 50, 2000, [&](int i) { sink = sink + robot->jacobian(pick(i))(0, 0); });
    report("isValid (sliding)", 50, 1000, [&](int i) { sink = sink + world.isValid(pick(i)); });
    report("isValid (free)", 50, 1000, [&](int i) { sink = sink + world.isValid(pick(i), ContactMode::Free); });
    std::vector<Eigen::VectorXd> nearby;
    for (const auto &q : configurations)
        nearby.push_back(q + Eigen::VectorXd::Constant(7, 0.05));
    report("ik (seed 0.05 rad away)", 20, 100, [&](int i) {
        Eigen::VectorXd q;
        const int k = i % targets.size();
        sink = sink + robot->ik(targets[k], nearby[k], rng, q);
    });
    report("ik (random restarts)", 20, 50, [&](int i) {
        Eigen::VectorXd q;
        sink = sink + robot->ik(targets[i % targets.size()], Eigen::VectorXd(), rng, q);
    });

    // The Franka Panda of example-robot-data with its mesh collision model (the panda_square scene's
    // robot); argv[1] lists the directories where package:// resolves, ':'-separated.
    if (argc < 2)
        return 0;
    RobotSpec panda;
    std::stringstream dirs(argv[1]);
    for (std::string dir; std::getline(dirs, dir, ':');)
        if (!dir.empty())
            panda.packageDirs.push_back(dir);
    panda.source = resolveMeshUri("package://example-robot-data/robots/panda_description/urdf/panda.urdf", "",
                                  panda.packageDirs, "bench_core");
    std::ifstream file(panda.source);
    std::stringstream text;
    text << file.rdbuf();
    panda.urdf = text.str();
    panda.tipLink = "panda_leftfinger";
    panda.tipOffset.translation() << 0.0, 0.0076, 0.0545;
    panda.fixedJoints["panda_finger_joint1"] = 0.02;
    const auto pandaRobot = std::make_shared<RobotModel>(panda);
    CollisionWorld pandaWorld(pandaRobot, SupportSurface(square, 0.0), {}, {"panda_leftfinger"});
    std::vector<Eigen::VectorXd> pandaConfigurations;
    for (int i = 0; i < 2000; ++i)
        pandaConfigurations.push_back(pandaRobot->randomConfiguration(rng));
    const auto pickPanda = [&](int i) -> const Eigen::VectorXd & { return pandaConfigurations[i % pandaConfigurations.size()]; };
    report("panda fk", 50, 2000, [&](int i) { sink = sink + pandaRobot->fk(pickPanda(i)).translation().x(); });
    report("panda isValid (sliding)", 50, 1000, [&](int i) { sink = sink + pandaWorld.isValid(pickPanda(i)); });
    report("panda isValid (free)", 50, 1000,
           [&](int i) { sink = sink + pandaWorld.isValid(pickPanda(i), ContactMode::Free); });
    return 0;
}

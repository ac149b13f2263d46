// The hot path (FK, Jacobian, projection onto the constraint, seeded IK) must not touch the heap:
// this test binary's malloc counts calls (Eigen and operator new both allocate through it). Not built
// with the sanitizers, whose runtime owns malloc.
#include "slideplan/constraint.hpp"
#include "slideplan/planner.hpp"
#include "test_support.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <gtest/gtest.h>

namespace
{
    thread_local long allocations = 0;
}

extern "C" void *__libc_malloc(std::size_t size);  // glibc's allocator, which this malloc forwards to

extern "C" void *malloc(std::size_t size)
{
    ++allocations;
    return __libc_malloc(size);
}

namespace slideplan
{
    TEST(HotPath, KinematicsProjectionAndSeededIkDoNotAllocate)
    {
        const auto robot = testing::wamT42();
        Eigen::VectorXd q(7);
        q << 0.1, 0.8, 0.0, 1.6, 0.0, 0.6, 0.0;
        const Eigen::Isometry3d tip = robot->fk(q);
        PlannerParams params;
        const SlidingConstraint constraint(robot, tip.translation().z() + 0.01, params);
        Eigen::VectorXd seed = q, solution = q, projected = q;
        Eigen::VectorXd near = q;
        near(1) += 0.05;
        const Eigen::Isometry3d target = robot->fk(near);
        std::mt19937_64 rng(1);
        IkOptions single;
        single.maxAttempts = 1;
        Eigen::Isometry3d projectedTip;

        const long before = allocations;
        double sink = 0.0;
        for (int i = 0; i < 10; ++i)
        {
            sink += robot->fk(q).translation().x() + robot->jacobian(q)(0, 0);
            projected = q;
            sink += constraint.projectWithTip(projected, projectedTip) ? 1.0 : 0.0;
            sink += robot->ik(target, seed, rng, solution, single) ? 1.0 : 0.0;
        }
        EXPECT_EQ(allocations - before, 0);
        EXPECT_TRUE(std::isfinite(sink));
        EXPECT_TRUE(robot->ik(target, seed, rng, solution, single));  // the seeded IK above did solve
    }

    TEST(HotPath, ATreeNodeIsOneAllocation)
    {
        // Without collision shapes (FCL's GJK allocates inside every narrow-phase test) the allocations of
        // a plan are the planner's own: growing the trees dominates them, unless a node, a step or an
        // iteration allocates more than the node itself.
        std::ifstream file(testing::robotPath());
        const std::string urdf((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
        const std::string bare = std::regex_replace(urdf, std::regex("<collision[\\s\\S]*?</collision>"), "");
        ASSERT_NE(bare.size(), urdf.size());
        const auto robot = std::make_shared<RobotModel>(bare, "fingertip_contact", testing::defaultMount());
        Eigen::Matrix<double, Eigen::Dynamic, 3> plate(121, 3);
        for (int i = 0; i <= 10; ++i)
            for (int j = 0; j <= 10; ++j)
                plate.row(i * 11 + j) << 0.45 - 0.05 + 0.01 * i, 0.0 - 0.05 + 0.01 * j, 0.004;
        const auto task = std::make_shared<SlidingTask>(SlidingTask::make(
            robot, std::make_shared<SupportSurface>(testing::squareTable()), {},
            {"t42_finger1_proximal", "t42_finger1_distal"}, "t42_grasp", Eigen::Isometry3d::Identity(), plate,
            Eigen::Vector2d(0.45, 0.0)));
        PlannerParams params;
        // No pair is ever valid (the plate, turned by at most 0.2 rad, overhangs an edge by at most 5.4 cm
        // with its centre of mass 5 mm inside): the trees grow until the planner is stopped.
        params.uStar = 0.06;
        params.maxObjectYaw = 0.2;
        // Stopped after a number of termination checks, not a time, so that the same plan grows the same
        // trees on a busy machine; the longer plan repeats the shorter one and goes on.
        const auto grow = [&](long checks, long &nodes) {
            long calls = 0;
            const ompl::base::PlannerTerminationCondition stop([&calls, checks] { return ++calls > checks; });
            const long before = allocations;
            const PlanResult result = planSliding(task, params, 1, stop);
            EXPECT_EQ(result.status, "timeout");
            nodes = result.stats.nodes;
            return allocations - before;
        };
        long fewNodes = 0, manyNodes = 0;
        const long few = grow(500, fewNodes), many = grow(5000, manyNodes);
        ASSERT_GT(manyNodes - fewNodes, 10000);  // the set-up and the first roots cancel out in the difference
        // 1.50 here (root pairs add map entries, and each valid start root solves the line the reach comes
        // down on: about 18 allocations per root, a root per 70 nodes); 3.6 when a node held a VectorXd and
        // each step allocated.
        EXPECT_LT(static_cast<double>(many - few) / static_cast<double>(manyNodes - fewNodes), 2.0)
            << many - few << " allocations, " << manyNodes - fewNodes << " nodes";
    }
}  // namespace slideplan

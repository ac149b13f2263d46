// The hot path (FK, Jacobian, projection onto the constraint, seeded IK) must not touch the heap (issue 10):
// this test binary's malloc counts calls (Eigen and operator new both allocate through it). Not built
// with the sanitizers, whose runtime owns malloc.
#include "slideplan/constraint.hpp"
#include "test_support.hpp"

#include <cmath>
#include <cstdlib>
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
}  // namespace slideplan

#include "test_support.hpp"

#include "slideplan/straight_line.hpp"

#include <gtest/gtest.h>
#include <random>

using namespace slideplan;
using slideplan::testing::wamT42;

TEST(StraightLine, TheTipRisesOnTheLineACentimetreAtATimeOnOneBranch)
{
    const auto robot = wamT42();
    std::mt19937_64 sampler(21);
    const Eigen::Vector3d offset(0.0, 0.0, 0.045);  // 4.5 cm: 5 steps of 9 mm
    int moved = 0;
    for (int trial = 0; trial < 20; ++trial)
    {
        const Eigen::VectorXd q = robot->randomConfiguration(sampler);
        const Eigen::Isometry3d start = robot->fk(q);
        const auto path = straightLine(*robot, q, start, offset, IkOptions());
        if (!path)
            continue;
        ++moved;
        ASSERT_EQ(path->size(), 6u);
        EXPECT_EQ((*path)[0], q);
        for (std::size_t k = 1; k < path->size(); ++k)
        {
            const Eigen::Isometry3d pose = robot->fk((*path)[k]);
            EXPECT_LT((pose.translation() - (start.translation() + offset * (static_cast<double>(k) / 5.0))).norm(), 1e-6);
            EXPECT_TRUE(pose.linear().isApprox(start.linear(), 1e-6));  // the orientation kept
            EXPECT_LE(((*path)[k] - (*path)[k - 1]).cwiseAbs().maxCoeff(), kLiftJointStep);
        }
        const auto again = straightLine(*robot, q, start, offset, IkOptions());
        ASSERT_TRUE(again.has_value());
        EXPECT_EQ(again->back(), path->back());  // deterministic
    }
    EXPECT_GE(moved, 10) << "of 20 random configurations";
}

TEST(StraightLine, TheGraspFrameRisesWhenItsLinkIsGiven)
{
    const auto robot = wamT42();
    std::mt19937_64 sampler(5);
    int moved = 0;
    for (int trial = 0; trial < 10; ++trial)
    {
        const Eigen::VectorXd q = robot->randomConfiguration(sampler);
        const Eigen::Isometry3d start = robot->framePose(q, "t42_grasp");
        const auto path = straightLine(*robot, q, start, Eigen::Vector3d(0.0, 0.0, 0.02), IkOptions(), 0, "t42_grasp");
        if (!path)
            continue;
        ++moved;
        ASSERT_EQ(path->size(), 3u);
        EXPECT_LT((robot->framePose(path->back(), "t42_grasp").translation() - start.translation() -
                   Eigen::Vector3d(0.0, 0.0, 0.02)).norm(), 1e-6);
    }
    EXPECT_GE(moved, 5);
    const Eigen::VectorXd q = Eigen::VectorXd::Constant(7, 0.3);
    EXPECT_THROW(straightLine(*robot, q, robot->fk(q), Eigen::Vector3d(0.0, 0.0, 0.02), IkOptions(), 0, "wam_link3"),
                 std::invalid_argument);
}

TEST(StraightLine, NoLineWhereAStepHasNoIkOrLeavesTheBranch)
{
    const auto robot = wamT42();
    const Eigen::VectorXd q = Eigen::VectorXd::Constant(7, 0.3);
    const Eigen::Isometry3d start = robot->fk(q);
    // Out of reach: 3 m up.
    EXPECT_FALSE(straightLine(*robot, q, start, Eigen::Vector3d(0.0, 0.0, 3.0), IkOptions()).has_value());
    // A start 30 cm from where the tip is: the first step's IK is reached only by turning a joint further
    // than kLiftJointStep, which a straight move from q never does.
    Eigen::Isometry3d away = start;
    away.translation() += Eigen::Vector3d(-0.3, 0.0, 0.0);
    IkOptions one;
    one.maxAttempts = 1;
    std::mt19937_64 rng(0);
    Eigen::VectorXd reached;
    ASSERT_TRUE(robot->ik(away, q, rng, reached, one));  // reachable, but far in joint space
    ASSERT_GT((reached - q).cwiseAbs().maxCoeff(), kLiftJointStep);
    EXPECT_FALSE(straightLine(*robot, q, away, Eigen::Vector3d(0.0, 0.0, 0.005), one).has_value());
}

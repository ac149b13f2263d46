// The time parameterization (timing.hpp), checked from positions and times alone: no TOPP-RA inside.
#include "slideplan/timing.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

using namespace slideplan;
using slideplan::testing::wamT42;

namespace
{
    constexpr double kSlack = 1e-9;  // floating-point slack on "<= limit"

    TimingLimits limits(long dof, double velocity, double acceleration, double tip)
    {
        return {Eigen::VectorXd::Constant(dof, velocity), Eigen::VectorXd::Constant(dof, acceleration), tip};
    }

    /// Every limit by finite differences between waypoints: mean joint velocity, mean fingertip speed where capped,
    /// change of velocity per interval; and the reported velocities and accelerations.
    void expectWithinLimits(const Eigen::MatrixXd &path, const Eigen::MatrixXd &tips, const std::vector<bool> &capped,
                            const TimedPath &timed, const TimingLimits &limits)
    {
        const long count = path.rows();
        EXPECT_EQ(timed.timeFromStart(0), 0.0);
        EXPECT_TRUE(timed.velocities.row(0).isZero(0.0));
        EXPECT_TRUE(timed.velocities.row(count - 1).isZero(0.0));
        for (long i = 0; i < count; ++i)
        {
            EXPECT_LE((timed.velocities.row(i).transpose().cwiseAbs() - limits.jointVelocity).maxCoeff(), kSlack) << i;
            EXPECT_LE((timed.accelerations.row(i).transpose().cwiseAbs() - limits.jointAcceleration).maxCoeff(), kSlack) << i;
        }
        for (long i = 0; i + 1 < count; ++i)
        {
            const double dt = timed.timeFromStart(i + 1) - timed.timeFromStart(i);
            ASSERT_GT(dt, 0.0) << i;
            const Eigen::VectorXd mean = (path.row(i + 1) - path.row(i)).transpose() / dt;
            EXPECT_LE((mean.cwiseAbs() - limits.jointVelocity).maxCoeff(), kSlack) << i;
            const Eigen::VectorXd change = (timed.velocities.row(i + 1) - timed.velocities.row(i)).transpose().cwiseAbs() / dt;
            EXPECT_LE((change - limits.jointAcceleration).maxCoeff(), kSlack) << i;
            if (capped[i] || capped[i + 1])
                EXPECT_LE((tips.row(i + 1) - tips.row(i)).norm() / dt, limits.fingertipSpeed * (1.0 + kSlack)) << i;
        }
    }
}  // namespace

TEST(TimePath, AStraightJointPathTakesTheBangBangTime)
{
    // One joint, 1 rad, v_max 2, a_max 1, nothing capped: the time-optimal rest-to-rest profile accelerates
    // at a_max to the middle and back (v peaks at 1 < v_max): 2 s. Waypoints every 1 mm.
    const long count = 1001;
    Eigen::MatrixXd path(count, 1), tips = Eigen::MatrixXd::Zero(count, 3);
    path.col(0) = Eigen::VectorXd::LinSpaced(count, 0.0, 1.0);
    const TimingLimits bounds = limits(1, 2.0, 1.0, 1.0);
    const std::vector<bool> capped(count, false);
    const TimedPath timed = timePath(path, tips, capped, bounds);
    EXPECT_NEAR(timed.timeFromStart(count - 1), 2.0, 0.01);
    expectWithinLimits(path, tips, capped, timed, bounds);
}

TEST(TimePath, TheFingertipCapHoldsWhereCappedOnly)
{
    // A 7-joint path of the WAM: the first half capped at 1 cm/s, the second free. The capped half must be
    // slower than the cap allows and the whole path within every limit.
    const auto robot = wamT42();
    const long count = 60;
    Eigen::VectorXd from(7), to(7);
    from << 0.0, 1.2, 0.0, 1.8, 0.0, 0.3, 0.0;
    to << 0.4, 1.0, 0.1, 1.6, 0.2, 0.5, 0.3;
    Eigen::MatrixXd path(count, 7), tips(count, 3);
    std::vector<bool> capped(count);
    for (long i = 0; i < count; ++i)
    {
        path.row(i) = (from + (to - from) * static_cast<double>(i) / (count - 1)).transpose();
        tips.row(i) = robot->fk(path.row(i).transpose()).translation().transpose();
        capped[i] = i < count / 2;
    }
    const TimingLimits bounds = limits(7, 1.0, 1.0, 0.01);
    const TimedPath timed = timePath(path, tips, capped, bounds);
    expectWithinLimits(path, tips, capped, timed, bounds);
    double cappedLength = 0.0;
    for (long i = 0; i + 1 < count / 2; ++i)
        cappedLength += (tips.row(i + 1) - tips.row(i)).norm();
    EXPECT_GE(timed.timeFromStart(count / 2 - 1), cappedLength / bounds.fingertipSpeed * (1.0 - 1e-9));
}

TEST(TimePath, TwoWaypointsAndOneWaypointAreTimed)
{
    Eigen::MatrixXd path(2, 2), tips = Eigen::MatrixXd::Zero(2, 3);
    path << 0.0, 0.0, 0.5, -0.5;
    const TimingLimits bounds = limits(2, 1.0, 1.0, 1.0);
    const TimedPath timed = timePath(path, tips, {false, false}, bounds);
    EXPECT_GT(timed.timeFromStart(1), 0.0);
    expectWithinLimits(path, tips, {false, false}, timed, bounds);
    const TimedPath single = timePath(path.topRows(1), tips.topRows(1), {false}, bounds);
    EXPECT_EQ(single.timeFromStart.size(), 1);
    EXPECT_EQ(single.timeFromStart(0), 0.0);
}

TEST(TimePath, RejectsMalformedInput)
{
    Eigen::MatrixXd path = Eigen::MatrixXd::Zero(3, 2), tips = Eigen::MatrixXd::Zero(3, 3);
    const std::vector<bool> capped(3, false);
    EXPECT_THROW(timePath(path, tips, capped, limits(3, 1.0, 1.0, 1.0)), std::invalid_argument);  // 3 limits, 2 joints
    EXPECT_THROW(timePath(path, tips, capped, limits(2, 0.0, 1.0, 1.0)), std::invalid_argument);
    EXPECT_THROW(timePath(path, tips, capped, limits(2, 1.0, NAN, 1.0)), std::invalid_argument);
    EXPECT_THROW(timePath(path, tips, capped, limits(2, 1.0, 1.0, -1.0)), std::invalid_argument);
    EXPECT_THROW(timePath(path, tips.topRows(2), capped, limits(2, 1.0, 1.0, 1.0)), std::invalid_argument);
    path(1, 0) = INFINITY;
    EXPECT_THROW(timePath(path, tips, capped, limits(2, 1.0, 1.0, 1.0)), std::invalid_argument);
}

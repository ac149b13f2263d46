#include "slideplan/contact_frame.hpp"
#include "slideplan/paired_goal.hpp"
#include "slideplan/planner.hpp"
#include "slideplan/regions.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <set>
#include <ompl/base/PlannerData.h>
#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <thread>

using namespace slideplan;
using slideplan::testing::squareTable;
using slideplan::testing::wamT42;

namespace
{
    const std::vector<std::string> kContactLinks{"t42_finger1_proximal", "t42_finger1_distal"};
    const std::string kGraspLink = "t42_grasp";
    constexpr double kThickness = 0.004;

    /// A 10 cm square plate centred at `centre`, sampled on a 1 cm grid that includes its border.
    Eigen::Matrix<double, Eigen::Dynamic, 3> squarePlate(const Eigen::Vector2d &centre)
    {
        Eigen::Matrix<double, Eigen::Dynamic, 3> points(121, 3);
        for (int i = 0; i <= 10; ++i)
            for (int j = 0; j <= 10; ++j)
                points.row(i * 11 + j) << centre.x() - 0.05 + 0.01 * i, centre.y() - 0.05 + 0.01 * j, kThickness;
        return points;
    }

    std::shared_ptr<SlidingTask> plateTask(const Eigen::Vector2d &centre)
    {
        return std::make_shared<SlidingTask>(SlidingTask::make(wamT42(), std::make_shared<SupportSurface>(squareTable()),
                                                               {}, kContactLinks, kGraspLink, Eigen::Isometry3d::Identity(), squarePlate(centre), centre));
    }

    /// A sliding configuration with the fingertip at (x, y), yaw 0, pitch beta0, depth in the band.
    Eigen::VectorXd contactConfig(const SlidingTask &task, const PlannerParams &params, double x, double y)
    {
        Eigen::Isometry3d target = Eigen::Isometry3d::Identity();
        target.linear() = contactRotation(0.0, params.beta0);
        target.translation() << x, y, task.surfaceZ - 0.5 * (params.dzMin + params.dzMax);
        std::mt19937_64 rng(1);
        Eigen::VectorXd seed(7), q;
        seed << 0.0, 1.2, 0.0, 1.8, 0.0, 0.3, 0.0;
        EXPECT_TRUE(task.robot->ik(target, seed, rng, q));
        return q;
    }

    ompl::base::PlannerTerminationCondition within(double seconds)
    {
        return ompl::base::timedPlannerTerminationCondition(seconds);
    }

    /// A termination condition true after `n` calls: work bounded by iterations, not the clock.
    ompl::base::PlannerTerminationCondition afterCalls(int n)
    {
        auto calls = std::make_shared<int>(0);
        return ompl::base::PlannerTerminationCondition([calls, n] { return ++*calls > n; });
    }

    /// Every constraint of a solved plan, checked on the dense path with the planner's own tools.
    void expectValidPlan(const SlidingTask &task, const PlannerParams &params, const PlanResult &result)
    {
        ASSERT_EQ(result.status, "solved");
        ASSERT_FALSE(result.trajectory.empty());
        const SlidingConstraint constraint(task.robot, task.surfaceZ, params);
        CollisionWorld world(task.robot, *task.table, task.obstacles, task.contactLinks);
        for (std::size_t i = 0; i < result.trajectory.size(); ++i)
        {
            const Eigen::VectorXd &q = result.trajectory[i];
            const Eigen::Isometry3d tip = task.robot->fk(q);
            EXPECT_TRUE(constraint.satisfied(tip)) << "waypoint " << i << " residual " << constraint.residual(tip).transpose();
            EXPECT_TRUE(task.table->contains(tip.translation().head<2>())) << "waypoint " << i;
            EXPECT_TRUE(world.isValid(q)) << "waypoint " << i;
            EXPECT_TRUE(task.robot->withinLimits(q)) << "waypoint " << i;
            if (params.comSupported)  // Eq. 2 from the first waypoint leaves the centre of mass on the table
                EXPECT_TRUE(task.table->contains(objectMotion(task.robot->fk(result.trajectory.front()), tip).apply(task.objectCom)))
                    << "waypoint " << i;
            if (i > 0)
            {
                EXPECT_LE((q - result.trajectory[i - 1]).cwiseAbs().maxCoeff(), params.maxJointStep + 1e-12);
                EXPECT_LE((tip.translation() - task.robot->fk(result.trajectory[i - 1]).translation()).norm(),
                          params.maxTipStep + 1e-12);
            }
        }
        const PlanarMotion motion = objectMotion(task.robot->fk(result.trajectory.front()), task.robot->fk(result.trajectory.back()));
        EXPECT_NEAR(motion.x, result.objectMotion.x, 1e-12);
        EXPECT_NEAR(motion.yaw, result.objectMotion.yaw, 1e-12);
        EXPECT_GE(result.overhang, params.uStar);
        EXPECT_TRUE(task.table->contains(result.objectMotion.apply(task.objectCom)));
        EXPECT_TRUE(task.robot->linkPose(result.graspConfig, task.graspLink).isApprox(result.graspPose, 1e-6));
        ASSERT_FALSE(result.approach.empty());
        EXPECT_EQ(result.approach.front(), result.goalConfig);
        EXPECT_EQ(result.approach.back(), result.graspConfig);
    }
}  // namespace

TEST(CanAddRoot, FollowsEquationFive)
{
    std::mt19937_64 rng(3);
    for (int i = 0; i < 1000; ++i)
        EXPECT_TRUE(canAddRoot(0, 0, 100.0, rng));  // exp(0) = 1 > U[0, 1)
    constexpr int draws = 40000;
    for (const auto &[roots, nStar] : std::vector<std::pair<int, double>>{{100, 100.0}, {50, 10.0}, {30, 100.0}})
    {
        int added = 0;
        for (int i = 0; i < draws; ++i)
            added += canAddRoot(roots / 2, roots - roots / 2, nStar, rng);
        const double expected = std::exp(-roots / nStar);
        EXPECT_NEAR(static_cast<double>(added) / draws, expected, 4 * std::sqrt(expected * (1 - expected) / draws) + 1e-4);
    }
}

TEST(ObjectMotion, IsThePlanarMotionOfTheContactFrame)
{
    Eigen::Isometry3d start = Eigen::Isometry3d::Identity(), goal = Eigen::Isometry3d::Identity();
    start.linear() = contactRotation(0.3, 1.0);
    start.translation() << 0.5, 0.1, 0.0;
    goal.linear() = contactRotation(0.3 + 0.7, 1.1);
    goal.translation() << 0.4, -0.2, -0.01;
    const PlanarMotion motion = objectMotion(start, goal);
    EXPECT_NEAR(motion.yaw, 0.7, 1e-12);
    // The contact point itself is carried from its start to its goal position.
    EXPECT_TRUE(motion.apply(Eigen::Vector2d(0.5, 0.1)).isApprox(Eigen::Vector2d(0.4, -0.2), 1e-12));
}

TEST(SlidingConstraint, ProjectsNearbyConfigurationsIntoTheBands)
{
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    const SlidingConstraint constraint(task->robot, task->surfaceZ, params);
    const Eigen::VectorXd onManifold = contactConfig(*task, params, 0.6, 0.0);
    EXPECT_TRUE(constraint.satisfied(task->robot->fk(onManifold)));
    std::mt19937_64 rng(5);
    std::normal_distribution<double> noise(0.0, 0.05);
    int projected = 0;
    for (int i = 0; i < 100; ++i)
    {
        Eigen::VectorXd q = onManifold;
        for (int j = 0; j < 7; ++j)
            q(j) += noise(rng);
        if (!constraint.project(q))
            continue;
        ++projected;
        const ContactAngles angles = contactAngles(task->robot->fk(q).linear());
        const double depth = task->surfaceZ - task->robot->fk(q).translation().z();
        EXPECT_GE(depth, params.dzMin - params.projectionTolerance);
        EXPECT_LE(depth, params.dzMax + params.projectionTolerance);
        EXPECT_NEAR(angles.roll, 0.0, 2 * params.projectionTolerance);
        EXPECT_LE(std::abs(angles.pitch - params.beta0), params.deltaBeta + 2 * params.projectionTolerance);
    }
    EXPECT_GE(projected, 95);
}

TEST(PairValidator, AcceptsASlideThatLeavesAGraspableOverhang)
{
    // Plate centred at (0.45, -0.005); the finger pushes it 17 cm towards the side edge y = -0.20, so
    // its grid rows at y = -0.225, -0.215, -0.205 end beyond the edge (none lies on it).
    const auto task = plateTask({0.45, -0.005});
    PlannerParams params;
    const PairValidator validator(task, params);
    std::mt19937_64 rng(2);
    const PairVerdict verdict = validator.check(contactConfig(*task, params, 0.45, 0.025),
                                                contactConfig(*task, params, 0.45, -0.145), rng, within(5.0));
    EXPECT_TRUE(verdict.valid) << verdict.reason;
    EXPECT_NEAR(verdict.overhang.overhang, 0.025, 1e-6);
    EXPECT_EQ(verdict.overhang.outsideCount, 33);
    EXPECT_TRUE(verdict.overhang.comInside);
    EXPECT_TRUE(verdict.overhang.edge.outwardNormal.isApprox(Eigen::Vector2d(0, -1), 1e-12));
    // H_g approaches perpendicular to the edge, in the table plane, at the centroid of P_out.
    EXPECT_TRUE(verdict.graspPose.linear().col(2).isApprox(Eigen::Vector3d(0, 1, 0), 1e-9));
    EXPECT_NEAR(verdict.graspPose.translation().y(), -0.215, 1e-6);
    EXPECT_NEAR(verdict.graspPose.translation().z(), 0.5 * kThickness, 1e-12);
    ASSERT_FALSE(verdict.approach.empty());
    EXPECT_TRUE(task->robot->linkPose(verdict.approach.back(), "t42_grasp").isApprox(verdict.graspPose, 1e-6));
}

TEST(PairValidator, AGoalTheFingerCannotLiftOffFromFailsEveryPair)
{
    // A plank over the hand, its underside 5 cm above the highest link frame there: the hand fits under it
    // at the goal, but the finger cannot rise 5 cm (grasp_lift) from there.
    const auto free = plateTask({0.45, -0.005});
    PlannerParams params;
    const Eigen::VectorXd start = contactConfig(*free, params, 0.45, 0.025);
    const Eigen::VectorXd goal = contactConfig(*free, params, 0.45, -0.145);
    std::vector<Eigen::Isometry3d> poses;
    free->robot->linkPoses(goal, poses);
    double top = 0.0;
    for (const Eigen::Isometry3d &pose : poses)
        if (pose.translation().x() > 0.3)  // the links over the table: the hand and the forearm's end
            top = std::max(top, pose.translation().z());
    Obstacle plank;
    plank.pose.translation() << 0.5, -0.1, top + 0.06;
    plank.size << 0.3, 0.15, 0.02;
    const auto blocked = std::make_shared<SlidingTask>(SlidingTask::make(
        free->robot, free->table, {plank}, kContactLinks, kGraspLink, Eigen::Isometry3d::Identity(), squarePlate({0.45, -0.005}),
        {0.45, -0.005}));
    const PairValidator open(free, params), covered(blocked, params);
    EXPECT_TRUE(open.canLift(goal));
    EXPECT_FALSE(covered.canLift(goal));
    std::mt19937_64 rng(2);
    EXPECT_TRUE(open.check(start, goal, rng, within(5.0)).valid);
    const PairVerdict verdict = covered.check(start, goal, rng, within(5.0));
    EXPECT_FALSE(verdict.valid);
    EXPECT_EQ(verdict.reason, "cannot lift the finger off the object");
}

TEST(PairValidator, LiftsInShorterStepsWhereAStepWouldTurnAJointTooFar)
{
    // With a joint step of 0.004 rad, 7 mm of lift (0.8 max_tip_step) turns this arm's joints further:
    // the lift must go in shorter steps, each within the joint step, and still rise grasp_lift.
    const auto task = plateTask({0.45, -0.005});
    PlannerParams params;
    const Eigen::VectorXd start = contactConfig(*task, params, 0.45, 0.025);
    const Eigen::VectorXd goal = contactConfig(*task, params, 0.45, -0.145);
    params.maxJointStep = 0.004;
    const PairValidator validator(task, params);
    EXPECT_TRUE(validator.canLift(goal));
    std::mt19937_64 rng(2);
    const PairVerdict verdict = validator.check(start, goal, rng, within(5.0));
    ASSERT_TRUE(verdict.valid) << verdict.reason;
    // The fingertip rises from its contact depth to grasp_lift above the object's top (not by grasp_lift:
    // from 1-3 cm below the top that would leave it 2-4 cm above).
    const double lifted = task->surfaceZ + params.graspLift;
    Eigen::VectorXd previous = goal;
    std::size_t waypoints = 0;
    for (const Eigen::VectorXd &q : verdict.approach)
    {
        EXPECT_LE((q - previous).cwiseAbs().maxCoeff(), params.maxJointStep) << "lift waypoint " << waypoints;
        ++waypoints;
        previous = q;
        if (task->robot->fk(q).translation().z() >= lifted - 1e-6)
            break;
    }
    EXPECT_NEAR(task->robot->fk(previous).translation().z(), lifted, 1e-6);
    EXPECT_GT(waypoints, 7u);  // more than the 7 steps of 0.8 max_tip_step
}

TEST(PairedGoal, CarriesTheObjectToAGraspableOverhangWithTheContactInTheGoalBand)
{
    const auto task = plateTask({0.45, 0.0});
    PlannerParams params;
    params.comMargin = 0.005;
    params.maxObjectYaw = 0.5;
    params.maxYawRate = 2.0;  // rad/m: binds for slides shorter than 0.25 m
    const PairValidator validator(task, params);
    const Eigen::VectorXd start = contactConfig(*task, params, 0.46, 0.01);
    const Eigen::Isometry3d startTip = task->robot->fk(start);
    std::mt19937_64 rng(4);
    int drawn = 0;
    for (int k = 0; k < 40; ++k)
    {
        Eigen::Isometry3d target;
        if (!pairedGoalTarget(*task, params, validator, startTip, rng, target))
            continue;
        ++drawn;
        // The drawn goal frame is a contact frame of C_g: pitch beta0, roll 0, depth in the band, in P_g.
        const ContactAngles angles = contactAngles(target.linear());
        EXPECT_NEAR(angles.pitch, params.beta0, 1e-9);
        EXPECT_NEAR(angles.roll, 0.0, 1e-9);
        const double depth = task->surfaceZ - target.translation().z();
        EXPECT_GE(depth, params.dzMin);
        EXPECT_LE(depth, params.dzMax);
        const double inside = task->table->signedDistance(target.translation().head<2>());
        EXPECT_GT(inside, 0.0);
        EXPECT_LE(inside, params.dGoal);
        // Eq. 2 from the start frame to it leaves the object graspable, its CoM inside by com_margin.
        const Overhang overhang = validator.overhang(objectMotion(startTip, target));
        EXPECT_TRUE(validator.graspable(overhang)) << "held " << overhang.held;
        EXPECT_TRUE(overhang.comInside) << "CoM margin " << overhang.comMargin;
        EXPECT_LE(std::abs(overhang.motion.yaw), params.maxObjectYaw + 1e-12);
        // A turn the slide can make at max_yaw_rate along the straight line, and a grasp whose hand
        // clears the table.
        const double slide = (target.translation() - startTip.translation()).head<2>().norm();
        EXPECT_LE(std::abs(overhang.motion.yaw), params.maxYawRate * slide + 1e-9) << "slide " << slide;
        EXPECT_TRUE(validator.graspClear(overhang));
    }
    EXPECT_GE(drawn, 20);
}

TEST(StartRegion, DrawsContactsWithinTheContactRadiusOfTheCentreOfMass)
{
    const Eigen::Vector2d centre(0.45, 0.0);
    const auto task = plateTask(centre);
    const auto si = std::make_shared<ompl::base::SpaceInformation>(jointSpace(*task->robot));
    PlannerParams params;
    const auto validity = std::make_shared<SlidingValidity>(
        si, task, std::make_shared<SlidingConstraint>(task->robot, task->surfaceZ, params));
    std::mt19937_64 rng(5);
    double farthest = 0.0;
    for (const double radius : {0.02, 0.0})
    {
        params.contactRadius = radius;
        const StartRegion region(validity, params);
        farthest = 0.0;
        for (int i = 0; i < 500; ++i)
        {
            Eigen::Vector2d point;
            ASSERT_TRUE(region.samplePoint(rng, point));
            farthest = std::max(farthest, (point - centre).norm());
        }
        if (radius > 0.0)
            EXPECT_LE(farthest, radius + 1e-12);  // the plate's centre point is its centre of mass
    }
    EXPECT_GT(farthest, 0.05);  // 0: the whole plate, corners 7 cm out
}

TEST(SlidingPlanner, SolvesWithOnlyPairedGoalRoots)
{
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    params.pairedGoals = 1.0;
    expectValidPlan(*task, params, planSliding(task, params, 5, within(30.0)));
}

TEST(PairValidator, RejectsTooLittleOverhangAndACentreOfMassOffTheTable)
{
    const auto task = plateTask({0.505, 0.0});
    PlannerParams params;
    const PairValidator validator(task, params);
    std::mt19937_64 rng(2);
    const Eigen::VectorXd start = contactConfig(*task, params, 0.535, 0.0);
    const PairVerdict shortSlide = validator.check(start, contactConfig(*task, params, 0.435, 0.0), rng, within(5.0));
    EXPECT_FALSE(shortSlide.valid);
    EXPECT_EQ(shortSlide.reason, "overhang below u*");
    const PairVerdict tooFar = validator.check(start, contactConfig(*task, params, 0.315, 0.0), rng, within(5.0));
    EXPECT_FALSE(tooFar.valid);  // plate centre at 0.285: beyond the edge x = 0.30
    EXPECT_EQ(tooFar.reason, "centre of mass off the table or within com_margin of its edge");
    // Plate centre 3 mm inside the edge: too close for the default 5 mm margin, fine for the paper's "inside".
    const Eigen::VectorXd nearEdge = contactConfig(*task, params, 0.333, 0.0);
    EXPECT_EQ(validator.check(start, nearEdge, rng, within(5.0)).reason, "centre of mass off the table or within com_margin of its edge");
    PlannerParams paper = params;
    paper.comMargin = 0.0;
    EXPECT_NE(PairValidator(task, paper).check(start, nearEdge, rng, within(5.0)).reason,
              "centre of mass off the table or within com_margin of its edge");
}

TEST(PairValidator, MovesTheGraspAlongTheEdgeOntoTheObjectWhereTheCentroidHoldsNothing)
{
    // A U-shaped plate (2 mm grid): a 10 x 2 cm bar and two 2 x 8 cm horns, slid until 3 cm of both horns
    // overhang the edge x = 0.30. The centroid of P_out lies between the horns, on nothing.
    Eigen::Matrix<double, Eigen::Dynamic, 3> cloud(0, 3);
    std::vector<Eigen::Vector3d> points;
    for (int i = 0; i <= 50; ++i)
        for (int j = 0; j <= 50; ++j)
        {
            const Eigen::Vector2d p(0.32 + 0.002 * i, -0.05 + 0.002 * j);
            if (p.x() >= 0.40 - 1e-9 || std::abs(p.y()) >= 0.03 - 1e-9)
                points.emplace_back(p.x(), p.y(), kThickness);
        }
    cloud.resize(static_cast<long>(points.size()), 3);
    for (std::size_t k = 0; k < points.size(); ++k)
        cloud.row(static_cast<long>(k)) = points[k].transpose();
    const Eigen::Vector2d com = cloud.leftCols<2>().colwise().mean().transpose();
    const auto task = std::make_shared<SlidingTask>(SlidingTask::make(
        wamT42(), std::make_shared<SupportSurface>(squareTable()), {}, kContactLinks, kGraspLink, Eigen::Isometry3d::Identity(),
        cloud, com));
    PlanarMotion motion;
    motion.x = -0.05;  // the horns' ends from x = 0.32 to 0.27
    PlannerParams params;
    params.graspStandoff = 0.03;
    for (bool exact : {false, true})
    {
        const Overhang held = PairValidator(task, params).overhang(motion, exact);
        ASSERT_TRUE(held.holds);
        EXPECT_NEAR(held.outsideCentroid.y(), 0.0, 1e-9);
        EXPECT_GE(std::abs(held.graspPoint.y()), 0.03 - 0.005);  // on a horn (its points within grasp_hold / 2)
        EXPECT_LE(std::abs(held.graspPoint.y()), 0.05);
        EXPECT_NEAR(held.graspPoint.x(), 0.27, 1e-9);  // grasp_standoff beyond the edge, as before
        PlannerParams paper = params;
        paper.graspHold = 0.0;
        EXPECT_NEAR(PairValidator(task, paper).overhang(motion, exact).graspPoint.y(), 0.0, 1e-9);
        PlannerParams longer = params;
        longer.graspHold = 0.2;  // more than the plate's length: no strip holds it
        const Overhang none = PairValidator(task, longer).overhang(motion, exact);
        EXPECT_FALSE(none.holds);
        EXPECT_FALSE(PairValidator(task, longer).graspable(none));
    }
}

TEST(PairValidator, FixedResolutionFootprintAgreesWithTheDenseCloudWithinAMillimetre)
{
    // 60,000 random points on an L-shaped plate (a non-convex object), moved partly over the table edges.
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    Eigen::Matrix<double, Eigen::Dynamic, 3> cloud(60000, 3);
    for (long i = 0; i < cloud.rows();)
    {
        const Eigen::Vector2d p(0.45 + 0.12 * unit(rng), -0.06 + 0.12 * unit(rng));
        if (p.x() > 0.49 && p.y() > -0.02)
            continue;  // the missing quadrant of the L
        cloud.row(i++) << p.x(), p.y(), kThickness;
    }
    const Eigen::Vector2d com = cloud.leftCols<2>().colwise().mean().transpose();
    const auto task = std::make_shared<SlidingTask>(SlidingTask::make(
        wamT42(), std::make_shared<SupportSurface>(squareTable()), {}, kContactLinks, kGraspLink, Eigen::Isometry3d::Identity(),
        cloud, com));
    EXPECT_LT(task->footprintXY.rows(), 4000);  // bounded by the area (2 mm cells), not by the 60,000 points
    PairValidator validator(task, PlannerParams());
    std::uniform_real_distribution<double> shift(-0.25, 0.25), yaw(-M_PI, M_PI);
    int compared = 0;
    for (int k = 0; k < 300; ++k)
    {
        PlanarMotion motion;
        motion.yaw = yaw(rng);
        const Eigen::Vector2d target(0.5 + shift(rng), shift(rng));
        const Eigen::Vector2d rotated = Eigen::Rotation2Dd(motion.yaw) * Eigen::Vector2d(0.51, 0.0);
        motion.x = target.x() - rotated.x();
        motion.y = target.y() - rotated.y();
        const Overhang dense = validator.overhang(motion, true), compact = validator.overhang(motion, false);
        EXPECT_EQ(dense.comInside, compact.comInside);
        if (dense.outsideCount < 200 || compact.outsideCount == 0)
            continue;  // a sliver over the edge: cells straddling it dominate (and no grasp needs it)
        ++compared;
        EXPECT_LE((dense.outsideCentroid - compact.outsideCentroid).norm(), 1e-3) << "motion " << k;
        if (dense.edge.edge == compact.edge.edge)
            EXPECT_LE(std::abs(dense.overhang - compact.overhang), 1e-3) << "motion " << k;
    }
    EXPECT_GT(compared, 50);
}

TEST(SlidingPlanner, SolvesAndEveryWaypointSatisfiesTheConstraints)
{
    const auto task = plateTask({0.6, 0.05});
    PlannerParams params;
    const PlanResult result = planSliding(task, params, 7, within(30.0));
    expectValidPlan(*task, params, result);
    EXPECT_GE(result.stats.pairsChecked, 1);
    EXPECT_EQ(result.planner, "slideplan");
}

TEST(SlidingPlanner, ShortcutKeepsTheEndpointsAndShortensThePath)
{
    const auto task = plateTask({0.55, 0.05});
    PlannerParams raw;
    raw.shortcutAttempts = 0;
    PlannerParams shortened;
    shortened.shortcutAttempts = 100;
    const PlanResult before = planSliding(task, raw, 4, within(30.0));
    const PlanResult after = planSliding(task, shortened, 4, within(30.0));
    expectValidPlan(*task, shortened, after);  // every new waypoint is a checked constrained step
    ASSERT_EQ(before.status, "solved");
    // Same seed: the same tree path was found, then shortened between its unchanged endpoints.
    EXPECT_EQ(before.startConfig, after.startConfig);
    EXPECT_EQ(before.goalConfig, after.goalConfig);
    EXPECT_EQ(after.trajectory.front(), after.startConfig);
    EXPECT_EQ(after.trajectory.back(), after.goalConfig);
    // The shortcut keeps a walk only if it lowers fingertip travel + shortcut_yaw_weight x yaw travel.
    const auto cost = [&](const PlanResult &r) { return r.stats.fingertipPath + shortened.shortcutYawWeight * r.stats.yawTravel; };
    EXPECT_LT(cost(after), cost(before));
}

TEST(SlidingPlanner, SameSeedSameTrajectory)
{
    const auto task = plateTask({0.6, -0.05});
    PlannerParams params;
    const PlanResult first = planSliding(task, params, 11, within(30.0));
    const PlanResult second = planSliding(task, params, 11, within(30.0));
    ASSERT_EQ(first.status, "solved");
    ASSERT_EQ(first.trajectory.size(), second.trajectory.size());
    for (std::size_t i = 0; i < first.trajectory.size(); ++i)
        EXPECT_EQ(first.trajectory[i], second.trajectory[i]);
    EXPECT_EQ(first.approach.size(), second.approach.size());
}

TEST(SlidingPlanner, PlansInThreadsEqualTheirSequentialTwins)
{
    // One robot model and, in the threads, one grasp map shared by every task, as the Python API shares
    // them (docs/design.md 9); the sequential twins each probe a map of their own.
    const auto robot = wamT42();
    const std::vector<Eigen::Vector2d> centres{{0.6, -0.05}, {0.55, 0.08}, {0.62, 0.02}, {0.5, -0.1}};
    std::vector<std::shared_ptr<const SlidingTask>> tasks;
    for (const auto &centre : centres)
        tasks.push_back(std::make_shared<SlidingTask>(SlidingTask::make(
            robot, std::make_shared<SupportSurface>(squareTable()), {}, kContactLinks, kGraspLink, Eigen::Isometry3d::Identity(), squarePlate(centre), centre)));
    PlannerParams params;
    constexpr int kRuns = 3;
    std::vector<std::vector<PlanResult>> sequential(tasks.size()), threaded(tasks.size());
    for (std::size_t t = 0; t < tasks.size(); ++t)
        for (int run = 0; run < kRuns; ++run)
            sequential[t].push_back(planSliding(tasks[t], params, 20 + run, within(30.0)));
    const auto shared = std::make_shared<const GraspMap>(*tasks.front(), params);
    std::vector<std::thread> threads;
    for (std::size_t t = 0; t < tasks.size(); ++t)
        threads.emplace_back([&, t] {
            for (int run = 0; run < kRuns; ++run)
                threaded[t].push_back(planSliding(tasks[t], params, 20 + run, within(30.0), shared));
        });
    for (auto &thread : threads)
        thread.join();
    for (std::size_t t = 0; t < tasks.size(); ++t)
        for (int run = 0; run < kRuns; ++run)
        {
            const PlanResult &alone = sequential[t][run], &beside = threaded[t][run];
            ASSERT_EQ(alone.status, "solved") << "task " << t << " run " << run;
            ASSERT_EQ(beside.status, alone.status) << "task " << t << " run " << run;
            EXPECT_EQ(beside.trajectory, alone.trajectory) << "task " << t << " run " << run;
            EXPECT_EQ(beside.approach, alone.approach) << "task " << t << " run " << run;
            expectValidPlan(*tasks[t], params, beside);
        }
}

TEST(GraspMap, FitsOnlyItsOwnGeometryAndParameters)
{
    const auto robot = wamT42();
    const auto make = [&](double thickness, const SupportSurface &table) {
        Eigen::Matrix<double, Eigen::Dynamic, 3> points = squarePlate({0.6, 0.0});
        points.col(2).setConstant(table.height() + thickness);
        return std::make_shared<SlidingTask>(SlidingTask::make(robot, std::make_shared<SupportSurface>(table), {}, kContactLinks,
                                                               kGraspLink, Eigen::Isometry3d::Identity(), points, {0.6, 0.0}));
    };
    const auto task = make(kThickness, squareTable());
    PlannerParams params;
    const auto map = std::make_shared<const GraspMap>(*task, params);
    EXPECT_TRUE(map->fits(*make(kThickness, squareTable()), params));  // equal values, other objects
    EXPECT_FALSE(map->fits(*make(kThickness + 0.001, squareTable()), params));
    Polygon2 wider = squareTable().vertices();
    wider *= 1.1;
    EXPECT_FALSE(map->fits(*make(kThickness, SupportSurface(wider, squareTable().height())), params));
    PlannerParams standoff = params;
    standoff.graspStandoff += 0.01;
    EXPECT_FALSE(map->fits(*task, standoff));
    PlannerParams other = params;
    other.nStar *= 2;  // not a grasp parameter
    EXPECT_TRUE(map->fits(*task, other));
    EXPECT_THROW(planSliding(make(kThickness + 0.001, squareTable()), params, 1, within(1.0), map), std::invalid_argument);
}

TEST(GraspMap, CountsItsStretchesAndRefusesOthers)
{
    const auto task = plateTask({0.6, 0.0});
    const GraspMap map(*task, PlannerParams());
    const SupportSurface &table = *task->table;
    for (int i = 0; i < table.size(); ++i)
    {
        const double length = (table.vertices().row((i + 1) % table.size()) - table.vertices().row(i)).norm();
        EXPECT_EQ(map.stretchCount(i), static_cast<long>(std::floor(length / GraspMap::kStretch)) + 1);
        EXPECT_THROW(map.stretchGrasp({i, map.stretchCount(i)}), std::invalid_argument);
    }
    EXPECT_THROW(map.stretchCount(table.size()), std::invalid_argument);
    EXPECT_THROW(map.stretchGrasp({0, -1}), std::invalid_argument);
}

TEST(GraspMap, ItsGraspSeedsGraspTheirStretches)
{
    // Each reachable stretch keeps the grasp its probe found (the seed of grasps there): H_g of that
    // configuration is the side grasp at the stretch's centre, just far enough out for u*, the hand as
    // given or rolled by pi; an unreachable stretch keeps none.
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    const GraspMap map(*task, params);
    const SupportSurface &table = *task->table;
    const double beyond = std::max(params.graspStandoff, 0.5 * params.uStar);
    const double z = table.height() + 0.5 * task->thickness();
    int reachable = 0, unreachable = 0;
    for (int i = 0; i < table.size(); ++i)
    {
        const Eigen::Vector2d a = table.vertices().row(i).transpose(), b = table.vertices().row((i + 1) % table.size()).transpose();
        for (double along = 0.5 * GraspMap::kStretch; along < (b - a).norm(); along += GraspMap::kStretch)
        {
            const EdgeQuery edge = table.closestEdge(a + along * (b - a).normalized());
            if (edge.edge != i)
                continue;  // a corner's other edge
            const Eigen::VectorXd seed = map.graspSeed(edge);
            ASSERT_EQ(seed.size() > 0, map.reachable(edge)) << "edge " << i << " at " << along;
            // What check-scene asks by stretch: the same answer, and the H_g the probe tries.
            EXPECT_TRUE(map.answer(map.stretch(edge)).isApprox(seed, 0.0) || seed.size() == 0);
            EXPECT_TRUE(map.stretchGrasp(map.stretch(edge))
                            .isApprox(sideGraspPose(edge.closest + beyond * edge.outwardNormal, edge, z), 1e-9));
            if (seed.size() == 0)
            {
                ++unreachable;
                continue;
            }
            ++reachable;
            const Eigen::Isometry3d grasp = sideGraspPose(edge.closest + beyond * edge.outwardNormal, edge, z);
            Eigen::Isometry3d rolled = grasp;
            rolled.linear() = rolled.linear() * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
            const Eigen::Isometry3d reached = task->robot->linkPose(seed, kGraspLink);
            EXPECT_TRUE(reached.isApprox(grasp, 1e-6) || reached.isApprox(rolled, 1e-6)) << "edge " << i << " at " << along;
        }
    }
    EXPECT_GT(reachable, 0);
    EXPECT_GT(unreachable, 0);
}

TEST(PlannerParams, AsPublishedTurnsEveryDepartureOffAndKeepsThePapersValues)
{
    const PlannerParams paper = PlannerParams::asPublished();
    EXPECT_NO_THROW(paper.validate());
    EXPECT_FALSE(paper.screenPairs || paper.graspFlip || paper.graspMap || paper.goalGraspFilter || paper.liftCheck ||
                 paper.cacheVerdicts || paper.comSupported);
    EXPECT_EQ(paper.pairedGoals, 0.0);
    EXPECT_EQ(paper.contactRadius, 0.0);
    EXPECT_EQ(paper.shortcutAttempts, 0);
    EXPECT_EQ(paper.comMargin, 0.0);
    EXPECT_EQ(paper.maxYawRate, 0.0);
    EXPECT_EQ(paper.graspStandoff, 0.0);
    EXPECT_EQ(paper.graspHold, 0.0);
    EXPECT_GE(paper.maxObjectYaw, M_PI);
    // Section V: Delta_beta = 0.1 rad, Delta_Z = [0.5 cm, 2.5 cm], N* = 100.
    EXPECT_EQ(paper.deltaBeta, 0.1);
    EXPECT_EQ(paper.dzMin, 0.005);
    EXPECT_EQ(paper.dzMax, 0.025);
    EXPECT_EQ(paper.nStar, 100.0);
}

TEST(ParameterRegistry, EveryParameterHasAPaperValueOrSaysWhyNotAndItsValuesLieInItsBounds)
{
    const PlannerParams defaults, paper = PlannerParams::asPublished();
    std::set<std::string> names;
    for (const ParameterSpec &spec : parameters())
    {
        EXPECT_TRUE(names.insert(spec.name).second) << spec.name << " declared twice";
        EXPECT_FALSE(spec.doc.empty()) << spec.name;
        // A paper value, or the statement that the paper leaves the parameter open (and why).
        EXPECT_TRUE(spec.paper.has_value() || spec.paperSource.rfind("open", 0) == 0) << spec.name << ": " << spec.paperSource;
        EXPECT_EQ(spec.check(spec.defaultValue), "") << spec.name;
        EXPECT_EQ(spec.get(defaults), spec.defaultValue) << spec.name;
        if (spec.paper)
        {
            EXPECT_EQ(spec.check(*spec.paper), "") << spec.name;
            EXPECT_EQ(spec.get(paper), *spec.paper) << spec.name;
        }
        else
            EXPECT_EQ(spec.get(paper), spec.defaultValue) << spec.name;
    }
    // The paper's grasp is H_g exactly: every rotation tolerance is 0 in the paper preset.
    EXPECT_EQ(paper.graspTiltTolerance, 0.0);
    EXPECT_EQ(paper.graspYawTolerance, 0.0);
    EXPECT_EQ(paper.graspRollTolerance, 0.0);
    EXPECT_THROW(parameter("no_such_parameter"), std::invalid_argument);
}

TEST(ParameterRegistry, ValidateNamesTheParameterOutOfItsBoundsAndBothOfAPair)
{
    PlannerParams params;
    params.contactRadius = -1.0;
    try
    {
        params.validate();
        FAIL() << "a negative contact_radius was accepted";
    }
    catch (const std::invalid_argument &error)
    {
        EXPECT_EQ(std::string(error.what()).rfind("planner parameter contact_radius ", 0), 0u) << error.what();
    }
    params = PlannerParams();
    params.beta0 = 0.05;  // below the default delta_beta: the user set only beta0
    try
    {
        params.validate();
        FAIL() << "delta_beta >= beta0 was accepted";
    }
    catch (const std::invalid_argument &error)
    {
        const std::string what = error.what();
        EXPECT_NE(what.find("delta_beta = 0.1"), std::string::npos) << what;
        EXPECT_NE(what.find("beta0 = 0.05"), std::string::npos) << what;
    }
    params = PlannerParams();
    params.shortcutAttempts = -1;
    EXPECT_THROW(params.validate(), std::invalid_argument);
}

TEST(SlidingPlanner, ADeadlineAnywhereGivesTheSamePlanOrNone)
{
    // The deadline as a count of its own evaluations: it fires at the k-th. Whatever step it cuts (an
    // IK, a transfer, the shortcut), the planner returns the plan it makes without a deadline, or none.
    const auto task = plateTask({0.6, 0.05});
    const PlannerParams params;
    long evaluations = 0;
    const PlanResult full = planSliding(task, params, 7, ompl::base::PlannerTerminationCondition([&] {
                                            ++evaluations;
                                            return false;
                                        }));
    ASSERT_EQ(full.status, "solved");
    // k past the last evaluation never fires: the full plan. Any k within the run cuts a step, so no plan.
    for (long k = std::max(1L, evaluations - 60); k <= evaluations + 1; ++k)
    {
        long count = 0;
        const PlanResult result =
            planSliding(task, params, 7, ompl::base::PlannerTerminationCondition([&] { return ++count >= k; }));
        if (k <= evaluations)
        {
            EXPECT_EQ(result.status, "timeout") << "k = " << k << " of " << evaluations;
            EXPECT_TRUE(result.trajectory.empty()) << "k = " << k;
            continue;
        }
        ASSERT_EQ(result.status, "solved");
        ASSERT_EQ(result.trajectory.size(), full.trajectory.size());
        for (std::size_t i = 0; i < full.trajectory.size(); ++i)
            EXPECT_EQ(result.trajectory[i], full.trajectory[i]);
    }
}

TEST(SlidingPlanner, AsPublishedSolvesWithTheTreePathAndEveryConnectionChecked)
{
    const auto task = plateTask({0.6, 0.0});
    const PlannerParams params = PlannerParams::asPublished();
    const PlanResult result = planSliding(task, params, 3, within(30.0));
    expectValidPlan(*task, params, result);
    // Without verdict caching IsPairValid runs at every connection, as in Algorithm 1.
    EXPECT_EQ(result.stats.pairsChecked, result.stats.connections);
}

namespace
{
    /// The planner set up as planSliding sets it up, for the OMPL interface tests.
    struct OmplSetup
    {
        std::shared_ptr<const SlidingTask> task;
        ompl::base::SpaceInformationPtr si;
        std::shared_ptr<SlidingPlanner> planner;
        ompl::base::ProblemDefinitionPtr pdef;

        OmplSetup(std::shared_ptr<const SlidingTask> t, const PlannerParams &params, std::uint64_t seed) : task(std::move(t))
        {
            si = std::make_shared<ompl::base::SpaceInformation>(jointSpace(*task->robot));
            planner = std::make_shared<SlidingPlanner>(si, task, params, seed);
            si->setup();
            pdef = std::make_shared<ompl::base::ProblemDefinition>(si);
            planner->setProblemDefinition(pdef);
        }
    };

}  // namespace

TEST(SlidingPlanner, PlannerDataHoldsBothForests)
{
    OmplSetup setup(plateTask({0.6, 0.0}), PlannerParams(), 5);
    ASSERT_EQ(setup.planner->solve(within(30.0)), ompl::base::PlannerStatus::EXACT_SOLUTION);
    ompl::base::PlannerData data(setup.si);
    setup.planner->getPlannerData(data);
    const PlanStats &stats = setup.planner->result().stats;
    EXPECT_EQ(data.numVertices(), static_cast<unsigned>(stats.nodes));
    EXPECT_EQ(data.numStartVertices(), static_cast<unsigned>(stats.startRoots));
    EXPECT_EQ(data.numGoalVertices(), static_cast<unsigned>(stats.goalRoots));
    EXPECT_EQ(data.numEdges(), static_cast<unsigned>(stats.nodes - stats.startRoots - stats.goalRoots));  // a forest
}

TEST(SlidingPlanner, ASecondSolveReportsOnlyItself)
{
    OmplSetup setup(plateTask({0.6, 0.0}), PlannerParams(), 5);
    setup.planner->solve(afterCalls(20));
    const long first = setup.planner->result().stats.iterations;
    ASSERT_GT(first, 0);
    setup.planner->solve(afterCalls(1));  // at most one iteration
    EXPECT_LE(setup.planner->result().stats.iterations, 1);
    ompl::base::PlannerData data(setup.si);
    setup.planner->getPlannerData(data);
    EXPECT_GE(data.numVertices(), static_cast<unsigned>(first));  // the forests grew on
}

TEST(SlidingPlanner, StartsFromTheProblemDefinitionsStartStates)
{
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    const Eigen::VectorXd onObject = contactConfig(*task, params, 0.6, 0.0);
    OmplSetup setup(task, params, 5);
    ompl::base::ScopedState<> start(setup.si);
    for (unsigned i = 0; i < onObject.size(); ++i)
        start[i] = onObject(i);
    setup.pdef->addStartState(start);
    setup.planner->solve(afterCalls(0));  // no iteration: only the given root
    ompl::base::PlannerData data(setup.si);
    setup.planner->getPlannerData(data);
    ASSERT_EQ(data.numStartVertices(), 1u);
    const auto *root = data.getStartVertex(0).getState()->as<ompl::base::RealVectorStateSpace::StateType>();
    for (unsigned i = 0; i < onObject.size(); ++i)
        EXPECT_EQ(root->values[i], onObject(i));

    // A start state off the contact constraint (the fingertip 5 cm above the object) is refused.
    Eigen::Isometry3d above = task->robot->fk(onObject);
    above.translation().z() += 0.05;
    Eigen::VectorXd lifted;
    std::mt19937_64 rng(1);
    ASSERT_TRUE(task->robot->ik(above, onObject, rng, lifted));
    OmplSetup off(task, params, 5);
    ompl::base::ScopedState<> bad(off.si);
    for (unsigned i = 0; i < lifted.size(); ++i)
        bad[i] = lifted(i);
    off.pdef->addStartState(bad);
    EXPECT_EQ(off.planner->solve(afterCalls(10)), ompl::base::PlannerStatus::INVALID_START);
}

namespace
{
    /// plateTask's plate at `centre`, moved by `motion` (Eq. 2): the object where a plan has slid it, to
    /// plan from a state (it may overhang an edge).
    std::shared_ptr<const SlidingTask> plateTaskMoved(const Eigen::Vector2d &centre, const PlanarMotion &motion)
    {
        Eigen::Matrix<double, Eigen::Dynamic, 3> points = squarePlate(centre);
        for (Eigen::Index i = 0; i < points.rows(); ++i)
            points.row(i).head<2>() = motion.apply(points.row(i).head<2>().transpose()).transpose();
        return std::make_shared<SlidingTask>(SlidingTask::make(wamT42(), std::make_shared<SupportSurface>(squareTable()), {},
                                                               kContactLinks, kGraspLink, Eigen::Isometry3d::Identity(), points,
                                                               motion.apply(centre), true));
    }
}  // namespace

TEST(PlanSliding, PlansFromAStateDuringTheSlide)
{
    // Re-planning during a slide: from a waypoint a third of the way along a solved plan, with the object
    // where Eq. 2 puts it there, the new plan starts at that configuration exactly, draws no other start
    // root, passes every check, and is the same plan again for the same seed.
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    const PlanResult first = planSliding(task, params, 3, within(30.0));
    ASSERT_EQ(first.status, "solved");
    const std::size_t k = first.trajectory.size() / 3;
    ASSERT_GT(k, 0u);
    const auto there = plateTaskMoved({0.6, 0.0}, objectMotion(first.fingertipPoses.front(), first.fingertipPoses[k]));
    const Eigen::VectorXd from = first.trajectory[k];
    const PlanResult again = planSliding(there, params, 11, within(30.0), nullptr, from);
    expectValidPlan(*there, params, again);
    EXPECT_EQ(again.startConfig, from);
    EXPECT_EQ(again.trajectory.front(), from);
    EXPECT_EQ(again.stats.startRoots, 1);
    const PlanResult twin = planSliding(there, params, 11, within(30.0), nullptr, from);
    EXPECT_EQ(twin.trajectory, again.trajectory);
    EXPECT_EQ(twin.graspConfig, again.graspConfig);
}

TEST(PlanSliding, GraspsAtOnceFromAStateWhoseObjectAlreadyOverhangs)
{
    // The end of a slide, seen again: from a solved plan's last configuration with the object where Eq. 2
    // put it, the plan is that configuration and a grasp, no further slide; from its first it slides.
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    const PlanResult first = planSliding(task, params, 3, within(30.0));
    ASSERT_EQ(first.status, "solved");
    const auto there = plateTaskMoved({0.6, 0.0}, first.objectMotion);
    const PlanResult grasp = planSliding(there, params, 5, within(30.0), nullptr, first.goalConfig);
    expectValidPlan(*there, params, grasp);
    ASSERT_EQ(grasp.trajectory.size(), 1u);
    EXPECT_EQ(grasp.trajectory.front(), first.goalConfig);
    EXPECT_EQ(grasp.objectMotion.x, 0.0);
    EXPECT_EQ(grasp.objectMotion.yaw, 0.0);
    EXPECT_EQ(grasp.stats.iterations, 0);
    const PlanResult slide = planSliding(task, params, 5, within(30.0), nullptr, first.startConfig);
    expectValidPlan(*task, params, slide);
    EXPECT_GT(slide.trajectory.size(), 1u);
}

TEST(PlanSliding, RefusesAStartStateSayingWhyAndByHowMuch)
{
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    const Eigen::VectorXd onObject = contactConfig(*task, params, 0.6, 0.0);
    const auto message = [&](const Eigen::VectorXd &q) {
        try
        {
            planSliding(task, params, 1, afterCalls(100), nullptr, q);
        }
        catch (const InvalidStartConfig &error)
        {
            return std::string(error.what());
        }
        return std::string("accepted");
    };
    // The fingertip 2 cm above its depth band, found by IK so the rest of the pose is on the manifold.
    Eigen::Isometry3d raised = task->robot->fk(onObject);
    raised.translation().z() += 0.02 + 0.5 * (params.dzMax - params.dzMin);
    Eigen::VectorXd high;
    std::mt19937_64 rng(1);
    ASSERT_TRUE(task->robot->ik(raised, onObject, rng, high));
    const std::string text = message(high);
    const std::size_t at = text.find("the fingertip is ");
    ASSERT_NE(at, std::string::npos) << text;
    EXPECT_NEAR(std::stod(text.substr(at + 17)), 0.02, 1e-4) << text;
    EXPECT_NE(text.find("m above its depth band"), std::string::npos) << text;
    // On the manifold, but the fingertip 10 cm beside the plate.
    EXPECT_NE(message(contactConfig(*task, params, 0.6, 0.16)).find("not on the object"), std::string::npos);
    Eigen::VectorXd beyond = onObject;
    beyond(1) = task->robot->upperLimits()(1) + 0.1;
    EXPECT_NE(message(beyond).find("outside its limits"), std::string::npos) << message(beyond);
    EXPECT_NE(message(onObject.head(3)).find("has 3 joints, the robot 7"), std::string::npos);
    EXPECT_EQ(message(onObject), "accepted");
}

TEST(SlidingPlanner, CachedVerdictsCheckEachRootPairOnce)
{
    // Two tasks where connections repeat a root pair: with the cache every pair is checked once.
    int repeated = 0;
    for (std::uint64_t seed = 0; seed < 6; ++seed)
    {
        const auto task = plateTask({0.6, 0.0});
        PlannerParams params;
        params.screenPairs = false;  // screening would skip the known-bad pairs before they connect
        const PlanResult result = planSliding(task, params, seed, within(30.0));
        ASSERT_EQ(result.status, "solved") << "seed " << seed;
        EXPECT_LE(result.stats.pairsChecked, result.stats.connections);
        repeated += result.stats.pairsChecked < result.stats.connections;
    }
    EXPECT_GT(repeated, 0);
}

TEST(SlidingPlanner, ScreeningSkipsPairsTheFootprintRulesOut)
{
    // Screening steers connections away from root pairs that leave too little overhang, the centre of mass
    // off the table or too much turn: the same seeds check far fewer such pairs than without it. With its
    // per-tree flags in an unsigned plain char (as on aarch64; the sanitizer build compiles with
    // -funsigned-char) NearestTree's screening was silently off.
    const std::vector<std::string> screenable{"overhang below u*", "centre of mass off the table or within com_margin of its edge",
                                              "object turns more than max_object_yaw"};
    long screened = 0, unscreened = 0;
    for (std::uint64_t seed = 0; seed < 4; ++seed)
        for (const bool screen : {true, false})
        {
            PlannerParams params = PlannerParams::asPublished();
            params.screenPairs = screen;
            const PlanResult result = planSliding(plateTask({0.6, 0.0}), params, seed, afterCalls(200000));
            for (const std::string &reason : screenable)
            {
                const auto count = result.stats.rejections.find(reason);
                (screen ? screened : unscreened) += count == result.stats.rejections.end() ? 0 : count->second;
            }
        }
    // Over these seeds: 4 against 71; with the flags unsigned, 44 (root screening alone).
    EXPECT_GT(unscreened, 0);
    EXPECT_LT(4 * screened, unscreened) << screened << " screenable rejections with screening, " << unscreened << " without";
}

TEST(SlidingPlanner, BaselinesProduceValidPlansWhenTheySolve)
{
    const auto task = plateTask({0.6, 0.0});
    for (const char *name : {"cbirrt", "cbirrt2"})
    {
        int solved = 0;
        for (std::uint64_t seed = 0; seed < 4; ++seed)
        {
            PlannerParams params;
            params.policy = rootPolicyFromName(name);
            // Work bounded by termination-condition calls, not the clock: under the sanitizers the same
            // search takes several times longer, and must give the same verdict. So no timed RRTConnect
            // transfer either: straight transfers only.
            params.transferIterations = 0;
            const PlanResult result = planSliding(task, params, seed, afterCalls(2000000));
            EXPECT_EQ(result.planner, name);
            EXPECT_EQ(result.stats.startRoots, 1);
            if (params.policy == RootPolicy::Fixed)
                EXPECT_LE(result.stats.goalRoots, 1);
            if (result.status != "solved")
                continue;
            ++solved;
            expectValidPlan(*task, params, result);
            EXPECT_GT(result.stats.precomputeTime, 0.0);
        }
        // Fig. 11: the baselines fail more often than Algorithm 1, but on this plate every seed solves
        // far inside its limit.
        EXPECT_EQ(solved, 4) << name;
    }
}

TEST(SlidingPlanner, TimesOutCleanlyWithoutReachableRoots)
{
    // A reconfiguration range of zero, a needle-thin pitch band and an overhang the plate cannot reach
    // turning by at most 0.2 rad: valid input, but no plan; the planner must stop on time.
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    params.dzMax = params.dzMin;
    params.deltaBeta = 0.0;
    params.uStar = 0.06;
    params.maxObjectYaw = 0.2;
    const PlanResult result = planSliding(task, params, 1, within(0.3));
    EXPECT_LT(result.planningTime, 1.5);
    EXPECT_EQ(result.status, "timeout");  // at most 0.05 (cos 0.2 + sin 0.2) - 5 mm = 5.4 cm of overhang
    EXPECT_TRUE(result.trajectory.empty());
    EXPECT_TRUE(result.approach.empty());
}

TEST(SlidingPlanner, RejectsAnObjectTooSmallForUStarBeforeSearching)
{
    // The 10 cm plate's corners lie 7.07 cm from its centre of mass, which stays com_margin = 5 mm inside
    // the (convex) table: no pose overhangs an edge by more than 6.57 cm.
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    params.uStar = 0.066;
    try
    {
        planSliding(task, params, 1, within(10.0));
        FAIL() << "u* beyond what the plate can overhang was accepted";
    }
    catch (const std::invalid_argument &error)
    {
        EXPECT_NE(std::string(error.what()).find("too small for u_star"), std::string::npos) << error.what();
    }
    params.uStar = 0.065;  // reachable at a 45 degree turn: accepted (and searched)
    EXPECT_NO_THROW(planSliding(task, params, 1, within(0.2)));
}

TEST(SlidingPlanner, RejectsBadInput)
{
    const auto task = plateTask({0.6, 0.0});
    PlannerParams params;
    params.uStar = 0.5;  // larger than the plate
    EXPECT_THROW(planSliding(task, params, 1, within(1.0)), std::invalid_argument);
    params = PlannerParams();
    params.dzMin = 0.03;  // dz_min > dz_max
    EXPECT_THROW(planSliding(task, params, 1, within(1.0)), std::invalid_argument);
    EXPECT_THROW(plateTask({0.85, 0.0}), std::invalid_argument);  // half the plate off the table
    // A table far out of reach: the object on it cannot be touched.
    Polygon2 far(4, 2);
    far << 3.0, -0.3, 3.6, -0.3, 3.6, 0.3, 3.0, 0.3;
    const auto unreachable = std::make_shared<SlidingTask>(SlidingTask::make(
        wamT42(), std::make_shared<SupportSurface>(far, 0.0), {}, kContactLinks, kGraspLink, Eigen::Isometry3d::Identity(), squarePlate({3.3, 0.0}), {3.3, 0.0}));
    try
    {
        // The reachability check stops at the time limit (a plan not found in time is a timeout): a limit
        // far beyond the check's own work, so that a slow build (the sanitizers) on a busy machine still sees it.
        planSliding(unreachable, PlannerParams(), 1, within(60.0));
        FAIL() << "an unreachable object was accepted";
    }
    catch (const std::invalid_argument &error)
    {
        EXPECT_NE(std::string(error.what()).find("reach"), std::string::npos);
    }
}

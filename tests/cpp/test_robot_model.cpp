#include "test_support.hpp"

#include <gtest/gtest.h>
#include <cmath>
#include <random>
#include <thread>

using namespace slideplan;
using slideplan::testing::wamT42;

namespace
{
    /// Standard DH of the WAM (docs/design.md 7), written independently of the URDF.
    Eigen::Matrix4d dhFlange(const Eigen::VectorXd &q)
    {
        const double alpha[7] = {-M_PI / 2, M_PI / 2, -M_PI / 2, M_PI / 2, -M_PI / 2, M_PI / 2, -M_PI / 2};
        const double a[7] = {0, 0, 0.045, -0.045, 0, 0, 0};
        const double d[7] = {0, 0, 0.55, 0, 0.30, 0, 0.0609};
        Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
        for (int i = 0; i < 7; ++i)
        {
            const double ct = std::cos(q(i)), st = std::sin(q(i)), ca = std::cos(alpha[i]), sa = std::sin(alpha[i]);
            Eigen::Matrix4d step;
            step << ct, -st * ca, st * sa, a[i] * ct, st, ct * ca, -ct * sa, a[i] * st, 0, sa, ca, d[i], 0, 0, 0, 1;
            t = t * step;
        }
        return t;
    }
}  // namespace

TEST(RobotModel, LoadsTheWamWithSevenJointsAndLimits)
{
    const auto robot = wamT42();
    ASSERT_EQ(robot->dof(), 7u);
    EXPECT_EQ(robot->jointNames().front(), "wam_j1");
    EXPECT_NEAR(robot->lowerLimits()(3), -50 * M_PI / 180, 1e-9);
    EXPECT_NEAR(robot->upperLimits()(4), 75 * M_PI / 180, 1e-9);
}

TEST(RobotModel, FlangeForwardKinematicsMatchesStandardDh)
{
    const auto flange = wamT42("wam_flange", Eigen::Isometry3d::Identity());
    std::mt19937_64 rng(7);
    for (int i = 0; i < 50; ++i)
    {
        const Eigen::VectorXd q = flange->randomConfiguration(rng);
        const Eigen::Matrix4d expected = dhFlange(q);
        EXPECT_LT((flange->fk(q).matrix() - expected).cwiseAbs().maxCoeff(), 1e-9) << "configuration " << i;
    }
}

TEST(RobotModel, BasePoseMovesEveryFrame)
{
    const auto robot = wamT42();
    const auto unmounted = wamT42("fingertip_contact", Eigen::Isometry3d::Identity());
    const Eigen::VectorXd q = Eigen::VectorXd::Constant(7, 0.3);
    EXPECT_TRUE(robot->fk(q).isApprox(slideplan::testing::defaultMount() * unmounted->fk(q), 1e-12));
}

TEST(RobotModel, JacobianMatchesFiniteDifferences)
{
    const auto robot = wamT42();
    std::mt19937_64 rng(3);
    for (int trial = 0; trial < 10; ++trial)
    {
        const Eigen::VectorXd q = robot->randomConfiguration(rng);
        const auto jacobian = robot->jacobian(q);
        const Eigen::Isometry3d pose = robot->fk(q);
        constexpr double h = 1e-7;
        for (int j = 0; j < 7; ++j)
        {
            Eigen::VectorXd qh = q;
            qh(j) += h;
            const Eigen::Matrix<double, 6, 1> numeric = poseError(pose, robot->fk(qh)) / h;
            EXPECT_LT((numeric - jacobian.col(j)).norm(), 1e-5) << "joint " << j;
        }
    }
}

TEST(RobotModel, IkSolvesReachablePosesWithinLimits)
{
    const auto robot = wamT42();
    std::mt19937_64 sampler(11), rng(12);
    int solved = 0;
    constexpr int trials = 1000;
    for (int i = 0; i < trials; ++i)
    {
        const Eigen::VectorXd truth = robot->randomConfiguration(sampler);
        const Eigen::Isometry3d target = robot->fk(truth);
        Eigen::VectorXd q;
        if (!robot->ik(target, Eigen::VectorXd(), rng, q))
            continue;
        const Eigen::Matrix<double, 6, 1> error = poseError(robot->fk(q), target);
        EXPECT_TRUE(robot->withinLimits(q));
        EXPECT_LT(error.head<3>().norm(), 1e-6);
        EXPECT_LT(error.tail<3>().norm(), 1e-6);
        ++solved;
    }
    EXPECT_GE(solved, 995) << "IK solved " << solved << " of " << trials;
}

TEST(RobotModel, IkIsDeterministicForASeed)
{
    const auto robot = wamT42();
    std::mt19937_64 sampler(5);
    const Eigen::Isometry3d target = robot->fk(robot->randomConfiguration(sampler));
    Eigen::VectorXd first, second;
    std::mt19937_64 rngA(99), rngB(99);
    ASSERT_TRUE(robot->ik(target, Eigen::VectorXd(), rngA, first));
    ASSERT_TRUE(robot->ik(target, Eigen::VectorXd(), rngB, second));
    EXPECT_EQ(first, second);
}

TEST(RobotModel, IkAbandonsARestartStillFarOffAfterAbandonAfterIterations)
{
    const auto robot = wamT42();
    std::mt19937_64 sampler(3);
    const Eigen::Isometry3d target = robot->fk(robot->randomConfiguration(sampler));
    IkOptions options;
    options.maxAttempts = 5;
    options.abandonAfter = 2;  // no restart from a random configuration converges in two iterations
    const auto solves = [&](double abandonError) {
        options.abandonError = abandonError;
        std::mt19937_64 rng(4);
        Eigen::VectorXd q;
        return robot->ik(target, Eigen::VectorXd(), rng, q, options);
    };
    EXPECT_FALSE(solves(1e-3));
    EXPECT_TRUE(solves(1e3));  // never that far off: no restart is abandoned
}

TEST(RobotModel, IkCountsARotationInsideTheToleratedBandAsNone)
{
    const auto robot = wamT42();
    std::mt19937_64 sampler(21);
    const Eigen::VectorXd seed = robot->randomConfiguration(sampler);
    const Eigen::Isometry3d reached = robot->fk(seed);
    IkOptions options;
    options.maxAttempts = 1;
    options.rotationTolerance << 0.0, 0.0, 0.3;  // about the target's own z
    // The target turned by 0.2 rad about its z from where the seed is: inside the band, so the seed
    // itself is a solution and IK returns it untouched.
    Eigen::Isometry3d target = reached;
    target.linear() = reached.linear() * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    std::mt19937_64 rng(22);
    Eigen::VectorXd q;
    ASSERT_TRUE(robot->ik(target, seed, rng, q, options));
    EXPECT_EQ(q, seed);
    // Without the band the same target asks for the turn, and the seed is not a solution.
    ASSERT_TRUE(robot->ik(target, seed, rng, q, IkOptions()));
    EXPECT_GT((q - seed).norm(), 1e-3);
    // Turned by 0.5 rad: IK turns the hand to the band's edge, 0.3 rad from the target about its z only.
    target.linear() = reached.linear() * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    ASSERT_TRUE(robot->ik(target, seed, rng, q, options));
    const Eigen::AngleAxisd turn(target.linear().transpose() * robot->fk(q).linear());
    EXPECT_NEAR(turn.angle(), 0.3, 1e-6);
    EXPECT_NEAR(std::abs(turn.axis().z()), 1.0, 1e-6);
    EXPECT_LT((robot->fk(q).translation() - target.translation()).norm(), 1e-6);
    // About the world's axes: the same turn applied about the world z is free with world_axes.
    options.worldAxes = true;
    options.rotationTolerance << 0.0, 0.0, M_PI;
    target.linear() = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()).toRotationMatrix() * reached.linear();
    ASSERT_TRUE(robot->ik(target, seed, rng, q, options));
    EXPECT_EQ(q, seed);
}

TEST(RobotModel, GraspFrameIkUsesTheSameJoints)
{
    const auto robot = wamT42();
    std::mt19937_64 sampler(8), rng(9);
    const Eigen::VectorXd truth = robot->randomConfiguration(sampler);
    const Eigen::Isometry3d target = robot->linkPose(truth, "t42_grasp");
    Eigen::VectorXd q;
    ASSERT_TRUE(robot->ikForLink("t42_grasp", target, Eigen::VectorXd(), rng, q));
    EXPECT_TRUE(robot->linkPose(q, "t42_grasp").isApprox(target, 1e-6));
    EXPECT_THROW(robot->ikForLink("wam_link3", target, Eigen::VectorXd(), rng, q), std::invalid_argument);
}

TEST(RobotModel, RejectsBadUrdfs)
{
    EXPECT_THROW(RobotModel("<robot name='x'><link name='a'>", "a"), std::invalid_argument);
    EXPECT_THROW(RobotModel::fromFile("/nonexistent/robot.urdf", "tip"), std::invalid_argument);
    EXPECT_THROW(RobotModel::fromFile(slideplan::testing::robotPath(), "no_such_link"), std::invalid_argument);
    const std::string mesh =
        "<robot name='m'><link name='a'/><link name='b'><collision><geometry><mesh filename='x.stl'/></geometry>"
        "</collision></link><joint name='j' type='revolute'><parent link='a'/><child link='b'/><axis xyz='0 0 1'/>"
        "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>";
    try
    {
        RobotModel robot(mesh, "b");
        FAIL() << "mesh geometry was accepted";
    }
    catch (const std::invalid_argument &error)
    {
        EXPECT_NE(std::string(error.what()).find("mesh"), std::string::npos);
    }
}

namespace
{
    /// The message of the invalid_argument building a robot from `urdf` (tip link "b") raises, empty if none;
    /// nothing may reach stderr.
    std::string refusal(const std::string &urdf)
    {
        ::testing::internal::CaptureStderr();
        std::string message;
        try
        {
            RobotModel robot(urdf, "b", Eigen::Isometry3d::Identity(), "r.urdf");
        }
        catch (const std::invalid_argument &error)
        {
            message = error.what();
        }
        EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
        return message;
    }
}  // namespace

// urdfdom drops a collision element it cannot read with only a line on stderr: the link then had no
// collision geometry and plans "verified" through it.
TEST(RobotModel, AUrdfdomErrorRefusesTheFileWithItsReasonAndNothingOnStderr)
{
    const std::string urdf =
        "<robot name='r'><link name='a'/><link name='b'><collision><geometry><sphere radius='nan'/></geometry>"
        "</collision></link><joint name='j' type='revolute'><parent link='a'/><child link='b'/><axis xyz='0 0 1'/>"
        "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>";
    for (const std::string &text : {urdf, std::string("<robot name='x'><link name='a'>")})
    {
        const std::string message = refusal(text);
        EXPECT_EQ(message.rfind("r.urdf: malformed URDF: ", 0), 0u) << message;
        if (text == urdf)
            EXPECT_NE(message.find("radius [nan] is not a valid float; Could not parse collision element for Link [b]"),
                      std::string::npos)
                << message;
    }
}

// urdfdom accepts a link that is the child of two joints (a loop a -> b -> c -> b: walking the tree never
// ended and died of std::bad_alloc) and a loop away from the root (c -> d -> c: its links owned each other).
TEST(RobotModel, AJointLoopIsRefusedNamingTheLink)
{
    const std::string links = "<robot name='r'><link name='a'/><link name='b'/><link name='c'/><link name='d'/>"
                              "<joint name='ab' type='fixed'><parent link='a'/><child link='b'/></joint>";
    const auto joint = [](const std::string &name, const std::string &parent, const std::string &child) {
        return "<joint name='" + name + "' type='fixed'><parent link='" + parent + "'/><child link='" + child + "'/></joint>";
    };
    const std::vector<std::pair<std::string, std::string>> cases{
        {links + joint("bc", "b", "c") + joint("cb", "c", "b") + joint("cd", "c", "d") + "</robot>",
         "r.urdf: malformed URDF: link 'b' is the child of two joints ('ab', 'cb')"},
        {links + joint("cd", "c", "d") + joint("dc", "d", "c") + "</robot>",
         "r.urdf: malformed URDF: link 'c' is not connected to the root (its joints form a loop)"}};
    for (const auto &[urdf, expected] : cases)
        EXPECT_EQ(refusal(urdf), expected);
}

TEST(RobotModel, KernelMatchesKdlForEveryLinkAndTheJacobian)
{
    const auto robot = wamT42();
    std::mt19937_64 rng(11);
    std::vector<Eigen::Isometry3d> poses;
    for (int i = 0; i < 50; ++i)
    {
        const Eigen::VectorXd q = robot->randomConfiguration(rng);
        robot->linkPoses(q, poses);
        for (std::size_t l = 0; l < robot->links().size(); ++l)
        {
            const Eigen::Isometry3d kdl = robot->referenceFramePose(q, robot->links()[l].name);
            EXPECT_LT((poses[l].matrix() - kdl.matrix()).cwiseAbs().maxCoeff(), 1e-12) << robot->links()[l].name;
        }
        EXPECT_LT((robot->fk(q).matrix() - robot->referenceFramePose(q, robot->tipLink()).matrix()).cwiseAbs().maxCoeff(), 1e-12);
        EXPECT_LT((robot->jacobian(q) - robot->referenceJacobian(q)).cwiseAbs().maxCoeff(), 1e-12) << "configuration " << i;
    }
}

TEST(RobotModel, KernelMatchesKdlForEveryJointAxisKind)
{
    // The WAM turns about z only; the kernel has separate paths for x, -y, a general axis and prismatic joints.
    const auto joint = [](const std::string &name, const std::string &type, const std::string &parent,
                          const std::string &child, const std::string &axis) {
        return "<link name='" + child + "'/><joint name='" + name + "' type='" + type + "'><parent link='" + parent +
               "'/><child link='" + child + "'/><origin xyz='0.1 0.02 0.3' rpy='0.3 -0.2 0.5'/><axis xyz='" + axis +
               "'/><limit lower='-2' upper='2' effort='1' velocity='1'/></joint>";
    };
    const std::string urdf = "<robot name='axes'><link name='base'/>" + joint("j1", "revolute", "base", "l1", "1 0 0") +
                             joint("j2", "revolute", "l1", "l2", "0 -1 0") + joint("j3", "revolute", "l2", "l3", "0.6 0 0.8") +
                             joint("j4", "prismatic", "l3", "l4", "0 0.8 0.6") + joint("j5", "revolute", "l4", "l5", "0 0 -1") +
                             "</robot>";
    const RobotModel robot(urdf, "l5");
    ASSERT_EQ(robot.dof(), 5u);
    std::mt19937_64 rng(5);
    std::vector<Eigen::Isometry3d> poses;
    for (int i = 0; i < 20; ++i)
    {
        const Eigen::VectorXd q = robot.randomConfiguration(rng);
        robot.linkPoses(q, poses);
        for (std::size_t l = 0; l < robot.links().size(); ++l)
            EXPECT_LT((poses[l].matrix() - robot.referenceFramePose(q, robot.links()[l].name).matrix()).cwiseAbs().maxCoeff(),
                      1e-12)
                << robot.links()[l].name;
        EXPECT_LT((robot.jacobian(q) - robot.referenceJacobian(q)).cwiseAbs().maxCoeff(), 1e-12) << "configuration " << i;
    }
}

TEST(RobotModel, ConstCallsFromManyThreadsGiveTheSequentialAnswers)
{
    // KDL caches joint poses in mutable members; a shared model must still answer every thread exactly.
    const auto robot = wamT42();
    std::mt19937_64 rng(3);
    std::vector<Eigen::VectorXd> configurations;
    for (int i = 0; i < 400; ++i)
        configurations.push_back(robot->randomConfiguration(rng));
    std::vector<Eigen::Matrix4d> expected;
    for (const auto &q : configurations)
        expected.push_back(robot->fk(q).matrix());
    std::vector<int> mismatches(4, 0);
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] {
            for (int repeat = 0; repeat < 20; ++repeat)
                for (std::size_t i = 0; i < configurations.size(); ++i)
                    mismatches[t] += robot->fk(configurations[(i + t * 97) % configurations.size()]).matrix() !=
                                     expected[(i + t * 97) % configurations.size()];
        });
    for (auto &thread : threads)
        thread.join();
    for (int t = 0; t < 4; ++t)
        EXPECT_EQ(mismatches[t], 0) << "thread " << t;
}

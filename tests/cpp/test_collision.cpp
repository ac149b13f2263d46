#include "slideplan/collision.hpp"
#include "slideplan/contact_frame.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <set>

using namespace slideplan;
using slideplan::testing::squareTable;
using slideplan::testing::wamT42;

namespace
{
    const std::vector<std::string> kContactLinks{"t42_finger1_proximal", "t42_finger1_distal"};

    /// A configuration pressing the fingertip `depth` below the table top at (x, y), pitch `pitch`.
    Eigen::VectorXd pressing(const RobotModel &robot, double x, double y, double depth, double pitch = 1.0)
    {
        Eigen::Isometry3d target = Eigen::Isometry3d::Identity();
        target.linear() = contactRotation(0.0, pitch);
        target.translation() << x, y, -depth;
        std::mt19937_64 rng(4);
        Eigen::VectorXd q;
        // Prefer an elbow-up solution: seed from a configuration leaning towards the table.
        Eigen::VectorXd seed(7);
        seed << 0.0, 1.0, 0.0, 1.5, 0.0, 0.5, 0.0;
        EXPECT_TRUE(robot.ik(target, seed, rng, q));
        return q;
    }
}  // namespace

TEST(CollisionWorld, UprightArmIsFree)
{
    const auto robot = wamT42();
    CollisionWorld world(robot, squareTable(), {}, kContactLinks);
    EXPECT_TRUE(world.isValid(Eigen::VectorXd::Zero(7)));
    EXPECT_TRUE(world.isValid(Eigen::VectorXd::Zero(7), ContactMode::Free));
    EXPECT_GT(world.selfPairCount(), 10u);
}

TEST(CollisionWorld, ContactFingerMayPenetrateOnlyWhileSliding)
{
    const auto robot = wamT42();
    CollisionWorld world(robot, squareTable(), {}, kContactLinks);
    const Eigen::VectorXd shallow = pressing(*robot, 0.6, 0.0, 0.015);
    EXPECT_TRUE(world.isValid(shallow, ContactMode::Sliding));
    EXPECT_FALSE(world.isValid(shallow, ContactMode::Free));
    const auto hits = world.collisions(shallow, ContactMode::Free);
    ASSERT_FALSE(hits.empty());
    EXPECT_EQ(hits.front().second, "table");
    EXPECT_EQ(hits.front().first.rfind("t42_finger1", 0), 0u);

    // Pressed so deep that the palm enters the table: invalid in both modes.
    const Eigen::VectorXd deep = pressing(*robot, 0.6, 0.0, 0.14);
    EXPECT_FALSE(world.isValid(deep, ContactMode::Sliding));
}

TEST(CollisionWorld, BoxObstaclesAndTheObjectBlock)
{
    const auto robot = wamT42();
    const Eigen::VectorXd q = pressing(*robot, 0.6, 0.0, 0.01);
    const Eigen::Vector3d palm = robot->linkPose(q, "t42_palm").translation();
    Obstacle box;
    box.pose.translation() = palm;
    box.size << 0.05, 0.05, 0.05;
    CollisionWorld blocked(robot, squareTable(), {box}, kContactLinks);
    EXPECT_FALSE(blocked.isValid(q));
    EXPECT_EQ(blocked.collisions(q).front().second, "obstacle0");
    EXPECT_THROW(blocked.objectFree(q), std::logic_error);
    blocked.setObject({{0.0, 0.3}, {0.05, 0.3}, {0.0, 0.35}}, 0.004);
    EXPECT_TRUE(blocked.objectFree(q));  // the box is not the object

    CollisionWorld world(robot, squareTable(), {}, kContactLinks);
    const Eigen::Vector3d tip = robot->fk(q).translation();
    const std::vector<Eigen::Vector2d> square{{tip.x() - 0.05, tip.y() - 0.05}, {tip.x() + 0.05, tip.y() - 0.05},
                                              {tip.x() + 0.05, tip.y() + 0.05}, {tip.x() - 0.05, tip.y() + 0.05}};
    world.setObject(square, 0.004);
    EXPECT_TRUE(world.isValid(q, ContactMode::Sliding));  // the finger presses on it
    world.clearObject();
    // An object tall enough to reach the palm blocks even while sliding.
    world.setObject(square, palm.z());
    EXPECT_FALSE(world.isValid(q, ContactMode::Sliding));
}

TEST(CollisionWorld, MovedObjectBlocksAsIfSetThere)
{
    const auto robot = wamT42();
    const Eigen::VectorXd q = pressing(*robot, 0.6, 0.0, 0.01);
    const double top = robot->linkPose(q, "t42_palm").translation().z();  // tall enough to reach the palm
    const std::vector<Eigen::Vector2d> outline{{0.25, 0.1}, {0.35, 0.1}, {0.35, 0.16}, {0.25, 0.16}};
    CollisionWorld moved(robot, squareTable(), {}, kContactLinks), placed(robot, squareTable(), {}, kContactLinks);
    EXPECT_THROW(moved.moveObject(PlanarMotion{}), std::logic_error);
    moved.setObject(outline, top);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> shift(-0.1, 0.45), turn(-M_PI, M_PI);
    int blocked = 0, free = 0;
    for (int k = 0; k < 200; ++k)
    {
        const PlanarMotion motion{shift(rng), shift(rng) - 0.2, turn(rng)};
        std::vector<Eigen::Vector2d> there;
        for (const Eigen::Vector2d &vertex : outline)
            there.push_back(motion.apply(vertex));
        moved.moveObject(motion);
        placed.setObject(there, top);
        const bool valid = moved.isValid(q, ContactMode::Sliding);
        EXPECT_EQ(valid, placed.isValid(q, ContactMode::Sliding)) << motion.x << " " << motion.y << " " << motion.yaw;
        EXPECT_EQ(valid, moved.objectFree(q, ContactMode::Sliding));  // q meets nothing else
        (valid ? free : blocked) += 1;
    }
    EXPECT_GT(blocked, 10);  // both verdicts occur, so the comparison means something
    EXPECT_GT(free, 10);
}

TEST(CollisionWorld, CloneAnswersAsTheOriginalAndIsIndependent)
{
    const auto robot = wamT42();
    Obstacle box;
    box.pose.translation() << 0.5, 0.1, 0.1;
    box.size << 0.1, 0.1, 0.2;
    CollisionWorld world(robot, squareTable(), {box}, kContactLinks);
    world.setObject({{0.45, -0.1}, {0.55, -0.1}, {0.5, 0.0}}, 0.05);
    const auto copy = world.clone();
    EXPECT_EQ(copy->selfPairCount(), world.selfPairCount());
    std::mt19937_64 rng(8);
    int hits = 0;
    for (int k = 0; k < 300; ++k)
    {
        const Eigen::VectorXd q = robot->randomConfiguration(rng);
        for (const ContactMode mode : {ContactMode::Sliding, ContactMode::Free})
        {
            EXPECT_EQ(copy->collisions(q, mode), world.collisions(q, mode));
            hits += !world.isValid(q, mode);
        }
    }
    EXPECT_GT(hits, 30);  // the configurations meet the table, the box, the object and the arm itself
    const Eigen::VectorXd q = pressing(*robot, 0.5, -0.05, 0.01);
    const double top = robot->linkPose(q, "t42_palm").translation().z();
    copy->setObject({{0.45, -0.1}, {0.55, -0.1}, {0.5, 0.0}}, top);
    EXPECT_FALSE(copy->isValid(q));
    EXPECT_TRUE(world.isValid(q));  // the original keeps its own, thin object
}

TEST(CollisionWorld, RigidFreeAnswersForTheHandAsTheFullCheck)
{
    // The links rigid with the grasp frame, found as those whose pose relative to it does not change
    // between two configurations: the hand past the wrist.
    const auto robot = wamT42();
    std::mt19937_64 rng(11);
    const Eigen::VectorXd a = robot->randomConfiguration(rng), b = robot->randomConfiguration(rng);
    std::set<std::string> hand;
    for (const RobotLink &link : robot->links())
        if ((robot->linkPose(a, "t42_grasp").inverse() * robot->linkPose(a, link.name))
                .isApprox(robot->linkPose(b, "t42_grasp").inverse() * robot->linkPose(b, link.name), 1e-9))
            hand.insert(link.name);
    ASSERT_GT(hand.count("t42_finger2_distal"), 0u);
    ASSERT_EQ(hand.count("wam_link1"), 0u);

    // A wide, high table and a box, so that random configurations put the hand into both often.
    Polygon2 wide(4, 2);
    wide << 0.2, -0.8, 1.0, -0.8, 1.0, 0.8, 0.2, 0.8;
    Obstacle box;
    box.pose.translation() << -0.5, 0.0, 0.4;
    box.size << 0.4, 1.0, 0.4;
    CollisionWorld world(robot, SupportSurface(wide, 0.3), {box}, kContactLinks);
    world.setObject({{0.3, -0.7}, {0.9, -0.7}, {0.6, 0.7}}, 0.9);  // not checked by rigidFree
    int free = 0, blocked = 0;
    for (int k = 0; k < 300; ++k)
    {
        const Eigen::VectorXd q = robot->randomConfiguration(rng);
        bool handHits = false;
        for (const auto &[link, piece] : world.collisions(q, ContactMode::Free))
            handHits = handHits || (hand.count(link) > 0 && piece != "object" && robot->linkIndex(piece) < 0);
        const bool rigidFree = world.rigidFree("t42_grasp", robot->linkPose(q, "t42_grasp"));
        EXPECT_EQ(rigidFree, !handHits) << q.transpose();
        // What it met, named as collisions() names it: a hand link and the table or the box.
        const std::string named = world.rigidCollision("t42_grasp", robot->linkPose(q, "t42_grasp"));
        EXPECT_EQ(named.empty(), rigidFree);
        if (!named.empty())
        {
            const std::string link = named.substr(0, named.find('-')), piece = named.substr(named.find('-') + 1);
            EXPECT_GT(hand.count(link), 0u) << named;
            EXPECT_TRUE(piece == "table" || robot->linkIndex(piece) < 0 && piece != "object") << named;
        }
        (rigidFree ? free : blocked) += 1;
    }
    EXPECT_GT(free, 30);  // both answers occur, so the comparison means something
    EXPECT_GT(blocked, 30);
    EXPECT_THROW(world.rigidFree("no_such_link", Eigen::Isometry3d::Identity()), std::invalid_argument);
}

TEST(CollisionWorld, FoldedArmCollidesWithItself)
{
    const auto robot = wamT42();
    CollisionWorld world(robot, squareTable(), {}, kContactLinks);
    Eigen::VectorXd folded = Eigen::VectorXd::Zero(7);
    folded(3) = robot->upperLimits()(3);  // elbow folded back onto the upper arm
    folded(5) = 1.5;
    const auto hits = world.collisions(folded, ContactMode::Free);
    ASSERT_FALSE(hits.empty());
    bool self = false;
    for (const auto &[a, b] : hits)
        self = self || (robot->linkIndex(a) >= 0 && robot->linkIndex(b) >= 0);
    EXPECT_TRUE(self);
}

TEST(CollisionWorld, RejectsUnknownContactLinks)
{
    EXPECT_THROW(CollisionWorld(wamT42(), squareTable(), {}, {"no_such_link"}), std::invalid_argument);
}

TEST(CollisionWorld, LinesOfSightAcrossTheArmAreHidden)
{
    const auto robot = wamT42();
    CollisionWorld world(robot, squareTable(), {}, kContactLinks);
    // Upright, the arm stands over its base: a line across the base's vertical halfway up crosses it, the
    // same line 0.4 m aside does not. With the shoulder pitched over, that height is clear.
    const Eigen::VectorXd upright = Eigen::VectorXd::Zero(7);
    std::vector<Eigen::Isometry3d> poses;
    robot->linkPoses(upright, poses);
    const Eigen::Vector3d foot = poses.front().translation(), top = robot->fk(upright).translation();
    const Eigen::Vector3d middle(foot.x(), foot.y(), 0.5 * (foot.z() + top.z()));
    const Eigen::Vector3d eye = middle - Eigen::Vector3d::UnitY();
    Eigen::Matrix<double, Eigen::Dynamic, 3> points(2, 3);
    points.row(0) = (middle + Eigen::Vector3d::UnitY()).transpose();
    points.row(1) = (middle + Eigen::Vector3d(0.4, 1.0, 0.0)).transpose();
    EXPECT_EQ(world.hiddenLines(upright, eye, points, 0.005), (std::vector<bool>{true, false}));
    Eigen::VectorXd bent = upright;
    bent(1) = 1.5;
    EXPECT_EQ(world.hiddenLines(bent, eye, points, 0.005), (std::vector<bool>{false, false}));
    EXPECT_THROW(world.hiddenLines(upright, eye, points, 0.0), std::invalid_argument);
    EXPECT_THROW(world.hiddenLines(upright, points.row(0).transpose(), points, 0.005), std::invalid_argument);
}

// docs/design.md 7: Debian's OMPL and KDL export Eigen::JacobiSVD<MatrixXd> with different layouts. This
// test runs OMPL's constraint projection (which uses the SVD) and our IK in one process: if the link
// order or visibility regresses, one of them aborts or returns garbage here.
#include "test_support.hpp"

#include <gtest/gtest.h>
#include <ompl/base/Constraint.h>

namespace
{
    class Sphere : public ompl::base::Constraint
    {
    public:
        Sphere() : ompl::base::Constraint(3, 1) {}
        void function(const Eigen::Ref<const Eigen::VectorXd> &x, Eigen::Ref<Eigen::VectorXd> out) const override
        {
            out[0] = x.norm() - 1.0;
        }
        void jacobian(const Eigen::Ref<const Eigen::VectorXd> &x, Eigen::Ref<Eigen::MatrixXd> out) const override
        {
            out = x.transpose().normalized();
        }
    };
}  // namespace

TEST(EigenAbi, OmplProjectionAndOurIkShareAProcess)
{
    Sphere sphere;
    Eigen::VectorXd x(3);
    x << 0.3, 1.7, -0.4;
    ASSERT_TRUE(sphere.project(x));
    EXPECT_NEAR(x.norm(), 1.0, 1e-6);

    const auto robot = slideplan::testing::wamT42();
    std::mt19937_64 sampler(1), rng(2);
    const Eigen::Isometry3d target = robot->fk(robot->randomConfiguration(sampler));
    Eigen::VectorXd q;
    ASSERT_TRUE(robot->ik(target, Eigen::VectorXd(), rng, q));
    EXPECT_LT(slideplan::poseError(robot->fk(q), target).norm(), 1e-6);

    Eigen::VectorXd y(3);
    y << -2.0, 0.1, 0.2;
    ASSERT_TRUE(sphere.project(y));
    EXPECT_NEAR(y.norm(), 1.0, 1e-6);
}

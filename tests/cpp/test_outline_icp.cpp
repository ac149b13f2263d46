#include "slideplan/outline_icp.hpp"

#include <gtest/gtest.h>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

using slideplan::OutlineIcp;
using slideplan::Points2;

namespace
{
    constexpr double kCell = 0.0005;
    constexpr double kInlier = 0.003;

    /// An L-shaped outline (no symmetry: one fit only), a point every 0.5 mm.
    Points2 lOutline()
    {
        const double corners[][2] = {{0, 0}, {0.08, 0}, {0.08, 0.02}, {0.02, 0.02}, {0.02, 0.06}, {0, 0.06}};
        std::vector<Eigen::Vector2d> points;
        for (int k = 0; k < 6; ++k)
        {
            const Eigen::Vector2d a(corners[k][0], corners[k][1]), b(corners[(k + 1) % 6][0], corners[(k + 1) % 6][1]);
            const int steps = static_cast<int>(std::round((b - a).norm() / 0.0005));
            for (int i = 0; i < steps; ++i)
                points.push_back(a + (b - a) * i / steps);
        }
        Points2 model(points.size(), 2);
        for (std::size_t i = 0; i < points.size(); ++i)
            model.row(i) = points[i].transpose();
        return model;
    }

    /// The nearest model point of each grid cell's corner, by brute force.
    OutlineIcp::IndexGrid grid(const Points2 &model, const Eigen::Vector2d &low, int cells)
    {
        OutlineIcp::IndexGrid index(cells, cells);
        for (int i = 0; i < cells; ++i)
            for (int j = 0; j < cells; ++j)
            {
                const Eigen::RowVector2d at(low.x() + (i + 0.5) * kCell, low.y() + (j + 0.5) * kCell);
                (model.rowwise() - at).rowwise().squaredNorm().minCoeff(&index(i, j));
            }
        return index;
    }

    Points2 moved(const Points2 &points, const Eigen::Vector3d &motion)
    {
        const double c = std::cos(motion.z()), s = std::sin(motion.z());
        Points2 out(points.rows(), 2);
        for (Eigen::Index i = 0; i < points.rows(); ++i)
            out.row(i) << c * points(i, 0) - s * points(i, 1) + motion.x(), s * points(i, 0) + c * points(i, 1) + motion.y();
        return out;
    }
}  // namespace

TEST(OutlineIcp, FindsTheMotionOfAPartlyHiddenOutlineAmongOutliers)
{
    const Points2 model = lOutline();
    const Eigen::Vector2d low(-0.02, -0.02);
    const OutlineIcp icp(model, grid(model, low, 240), low, kCell, kInlier);
    const Eigen::Vector3d truth(0.55, -0.07, 0.4);
    // Two thirds of the outline in view (the hand hides the rest), and 30 points of the hand's own
    // edge 2 cm beside it.
    const Points2 seen = moved(model.topRows(2 * model.rows() / 3), truth);
    Points2 points(seen.rows() + 30, 2);
    points.topRows(seen.rows()) = seen;
    for (int i = 0; i < 30; ++i)
        points.row(seen.rows() + i) << 0.55 + 0.001 * i, -0.07 - 0.02;
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> starts(2, 3);
    starts.row(0) = (truth + Eigen::Vector3d(0.004, -0.003, 0.05)).transpose();
    starts.row(1) = (truth + Eigen::Vector3d(-0.002, 0.003, -0.03)).transpose();
    for (const bool exact : {true, false})
    {
        const auto fits = icp.fit(points, starts, 40, exact, 0.1);
        ASSERT_EQ(fits.size(), 2u);
        for (const auto &fit : fits)
        {
            // Point-to-point ICP creeps along the outline at the end (it stops under 0.01 mm a step):
            // within a millimetre and 0.6 deg of the truth after 40 steps, every point in view explained.
            EXPECT_LT((fit.motion.head<2>() - truth.head<2>()).norm(), 0.001);
            EXPECT_LT(std::abs(fit.motion.z() - truth.z()), 0.01);
            EXPECT_EQ(fit.inliers, seen.rows());  // the hand's points are no inliers
            EXPECT_LT(fit.rmse, kCell);
        }
    }
    // No iteration: the start itself, scored.
    const auto unmoved = icp.fit(points, starts.topRows(1), 0, true, 0.1);
    EXPECT_TRUE(unmoved[0].motion.isApprox(starts.row(0).transpose()));
}

TEST(OutlineIcp, GridPairingIsWithinACellOfTheNearest)
{
    const Points2 model = lOutline();
    const Eigen::Vector2d low(-0.02, -0.02);
    const OutlineIcp icp(model, grid(model, low, 240), low, kCell, kInlier);
    std::mt19937 random(3);
    std::uniform_real_distribution<double> coordinate(-0.01, 0.09);
    Points2 points(500, 2);
    for (Eigen::Index i = 0; i < points.rows(); ++i)
        points.row(i) << coordinate(random), coordinate(random);
    Eigen::VectorXd exact, byGrid;
    Eigen::VectorXi exactIndex, gridIndex;
    icp.nearest(points, Eigen::Vector3d::Zero(), true, exact, exactIndex);
    icp.nearest(points, Eigen::Vector3d::Zero(), false, byGrid, gridIndex);
    for (Eigen::Index i = 0; i < points.rows(); ++i)
    {
        EXPECT_NEAR(exact(i), (model.row(exactIndex(i)) - points.row(i)).norm(), 1e-12);
        EXPECT_LE(exact(i), byGrid(i) + 1e-12);
        EXPECT_LE(byGrid(i), exact(i) + std::sqrt(2.0) * kCell);
    }
}

TEST(OutlineIcp, RejectsBadInput)
{
    const Points2 model = lOutline();
    const Eigen::Vector2d low(-0.02, -0.02);
    const auto index = grid(model, low, 20);
    EXPECT_THROW(OutlineIcp(Points2(0, 2), index, low, kCell, kInlier), std::invalid_argument);
    OutlineIcp::IndexGrid outside = index;
    outside(0, 0) = model.rows();
    EXPECT_THROW(OutlineIcp(model, outside, low, kCell, kInlier), std::invalid_argument);
    EXPECT_THROW(OutlineIcp(model, index, low, 0.0, kInlier), std::invalid_argument);
    EXPECT_THROW(OutlineIcp(model, index, low, kCell, std::nan("")), std::invalid_argument);
    const OutlineIcp icp(model, index, low, kCell, kInlier);
    Points2 points = model;
    points(3, 1) = std::numeric_limits<double>::infinity();
    const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> start = Eigen::RowVector3d::Zero();
    EXPECT_THROW(icp.fit(points, start, 10, true, 0.1), std::invalid_argument);
    EXPECT_THROW(icp.fit(model, start, -1, true, 0.1), std::invalid_argument);
}

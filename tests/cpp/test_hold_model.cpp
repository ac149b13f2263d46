#include "slideplan/hold_model.hpp"

#include <gtest/gtest.h>

using namespace slideplan;

namespace
{
    /// A plate sampled every millimetre over [x0, x0 + width] x [y0, y0 + depth] (m).
    Points2 grid(double x0, double y0, double width, double depth)
    {
        const int nx = static_cast<int>(std::lround(width / 1e-3)), ny = static_cast<int>(std::lround(depth / 1e-3));
        Points2 points((nx + 1) * (ny + 1), 2);
        for (int i = 0, row = 0; i <= nx; ++i)
            for (int j = 0; j <= ny; ++j)
                points.row(row++) << x0 + i * 1e-3, y0 + j * 1e-3;
        return points;
    }

    PlannerParams pads(double gripForce)
    {
        PlannerParams params;
        params.padWidth = 0.03;
        params.padLength = 0.04;
        params.gripForce = gripForce;
        params.objectDensity = 1000.0;
        return params;
    }
}  // namespace

TEST(HoldModel, WeighsGravitysMomentAgainstTheGripOverThePatch)
{
    // A 10 cm square plate, 4 mm thick (40 g), overhanging a table edge at x = 0.08 by 2 cm, grasped at the
    // middle of its x = 0.1 edge from +x: the pads (3 cm along the edge, 4 cm along the approach, centred on
    // H_g) hold the 3 cm x 2 cm strip inside the plate's edge, whose centre lies 1 cm in; the centre of mass
    // lies 4 cm further, along -x.
    const PlateRegion plate = plateRegion(grid(0.0, 0.0, 0.1, 0.1));
    const Eigen::Vector2d com(0.05, 0.05), grasp(0.1, 0.05), outward(1.0, 0.0);
    HoldEstimate estimate = estimateHold(plate, com, 0.004, grasp, 0.02, outward, pads(10.0));
    EXPECT_NEAR(estimate.mass, 0.04, 1e-9);
    EXPECT_NEAR(estimate.patchArea, 0.03 * 0.02, 1e-9);
    EXPECT_NEAR(estimate.lever, 0.04, 1e-9);
    EXPECT_NEAR(estimate.patchLength, 0.02, 1e-9);
    EXPECT_NEAR(estimate.demand, 0.04 * 9.81 * 0.04, 1e-9);
    EXPECT_NEAR(estimate.capacity, 10.0 * 0.02, 1e-9);
    EXPECT_TRUE(estimate.holds);  // 0.0157 N m against 0.2
    // A grip of 0.7 N resists 0.014 N m: the plate turns out of the pads.
    EXPECT_FALSE(estimateHold(plate, com, 0.004, grasp, 0.02, outward, pads(0.7)).holds);
    // Overhanging by 1 cm, the pads hold only the strip beyond the table's edge: the lower pad cannot reach
    // under the rest.
    estimate = estimateHold(plate, com, 0.004, grasp, 0.01, outward, pads(10.0));
    EXPECT_NEAR(estimate.patchArea, 0.03 * 0.01, 1e-9);
    EXPECT_NEAR(estimate.lever, 0.045, 1e-9);
    EXPECT_NEAR(estimate.capacity, 10.0 * 0.01, 1e-9);
}

TEST(HoldModel, FollowsTheLeverToACentreOfMassOutsideTheMaterial)
{
    // An L: a 10 cm x 2 cm bar along x and a 2 cm x 8 cm arm up its left end. Grasped at the bar's right
    // end, the pads hold the bar's 2 cm width across and the lever runs towards the corner, where the centre
    // of mass lies off the material, 6.2 cm away (a grip of 0.34 N needed over its 2.6 cm of patch along the lever);
    // the same hand holds the bar alone (0.16 N over 2 cm).
    Points2 bar = grid(0.0, 0.0, 0.1, 0.02), arm = grid(0.0, 0.021, 0.02, 0.079);
    Points2 l(bar.rows() + arm.rows(), 2);
    l << bar, arm;
    const PlateRegion plate = plateRegion(l);
    EXPECT_NEAR(plate.area, 0.1 * 0.02 + 0.02 * 0.08, 2e-5);  // the alpha shape bridges the 1 mm seam
    const Eigen::Vector2d grasp(0.1, 0.01), outward(1.0, 0.0);
    const HoldEstimate lEstimate = estimateHold(plate, plate.centroid, 0.004, grasp, 0.03, outward, pads(0.25));
    const PlateRegion barPlate = plateRegion(bar);
    const HoldEstimate barEstimate = estimateHold(barPlate, barPlate.centroid, 0.004, grasp, 0.03, outward, pads(0.25));
    EXPECT_GT(lEstimate.lever, barEstimate.lever);
    EXPECT_GT(lEstimate.demand, 2.0 * barEstimate.demand);
    EXPECT_TRUE(barEstimate.holds);
    EXPECT_FALSE(lEstimate.holds);
}

TEST(HoldModel, PadsOnAirHoldNothing)
{
    const PlateRegion plate = plateRegion(grid(0.0, 0.0, 0.1, 0.1));
    const HoldEstimate estimate = estimateHold(plate, plate.centroid, 0.004, Eigen::Vector2d(0.2, 0.05), 0.12,
                                               Eigen::Vector2d(1.0, 0.0), pads(100.0));
    EXPECT_EQ(estimate.patchArea, 0.0);
    EXPECT_FALSE(estimate.holds);
}

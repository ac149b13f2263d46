#include "slideplan/contact_frame.hpp"
#include "slideplan/area_centroid.hpp"
#include "slideplan/geometry.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <cmath>
#include <random>

using namespace slideplan;

namespace
{
    Polygon2 lShape()
    {
        Polygon2 l(6, 2);
        l << 0, 0, 2, 0, 2, 1, 1, 1, 1, 2, 0, 2;
        return l;
    }
}  // namespace

TEST(SupportSurface, PointInConvexAndNonConvexPolygons)
{
    const SupportSurface l(lShape(), 0.0);
    EXPECT_TRUE(l.contains({0.5, 0.5}));
    EXPECT_TRUE(l.contains({1.5, 0.5}));
    EXPECT_TRUE(l.contains({0.5, 1.5}));
    EXPECT_FALSE(l.contains({1.5, 1.5}));  // the notch
    EXPECT_FALSE(l.contains({-0.1, 0.5}));
    EXPECT_FALSE(l.isConvex());
    EXPECT_NEAR(l.area(), 3.0, 1e-12);

    Polygon2 round(100, 2);
    for (int i = 0; i < 100; ++i)
        round.row(i) << std::cos(2 * M_PI * i / 100), std::sin(2 * M_PI * i / 100);
    const SupportSurface circle(round, 0.0);
    EXPECT_TRUE(circle.isConvex());
    EXPECT_TRUE(circle.contains({0.99 * std::cos(0.3), 0.99 * std::sin(0.3)}));
    EXPECT_FALSE(circle.contains({1.01 * std::cos(0.3), 1.01 * std::sin(0.3)}));
}

TEST(SupportSurface, FastContainsAgreesWithTheWindingNumberEverywhere)
{
    // contains() settles points inside an inscribed disc and outside a circumscribed one at once; it must
    // agree with an independent winding-number test, also next to both discs and on a polygon whose
    // vertex mean lies outside it.
    const auto winding = [](const Polygon2 &polygon, const Eigen::Vector2d &p) {
        double angle = 0.0;
        for (int i = 0, n = static_cast<int>(polygon.rows()); i < n; ++i)
        {
            const Eigen::Vector2d a = polygon.row(i).transpose() - p, b = polygon.row((i + 1) % n).transpose() - p;
            angle += std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b));
        }
        return std::abs(angle) > M_PI;
    };
    Polygon2 round(100, 2), crescent(8, 2);
    for (int i = 0; i < 100; ++i)
        round.row(i) << 0.5 + 0.22 * std::cos(2 * M_PI * i / 100), 0.22 * std::sin(2 * M_PI * i / 100);
    crescent << 0, 0, 4, 0, 4, 4, 0, 4, 0, 3, 3, 3, 3, 1, 0, 1;  // a C whose vertex mean lies in its mouth
    std::mt19937_64 rng(2);
    for (const Polygon2 &polygon : {round, crescent, lShape()})
    {
        const SupportSurface surface(polygon, 0.0);
        const Eigen::Vector2d low = polygon.colwise().minCoeff(), high = polygon.colwise().maxCoeff();
        const Eigen::Vector2d mean = polygon.colwise().mean().transpose();
        std::uniform_real_distribution<double> u(-0.2, 1.2), turn(-M_PI, M_PI);
        int inside = 0;
        for (int k = 0; k < 20000; ++k)
        {
            Eigen::Vector2d p = low + (high - low).cwiseProduct(Eigen::Vector2d(u(rng), u(rng)));
            if (k % 2)  // half of them on rays from the mean, by the edges and the vertices
            {
                const double a = turn(rng);
                const Eigen::Vector2d ray(std::cos(a), std::sin(a));
                p = mean + ray * (surface.signedDistance(mean) > 0 ? std::abs(surface.signedDistance(mean)) : 0.0) *
                               (1.0 + 1e-3 * (u(rng) - 0.5));
            }
            if (std::abs(surface.signedDistance(p)) < 1e-12)
                continue;  // on the boundary either answer is right
            ASSERT_EQ(surface.contains(p), winding(polygon, p)) << p.transpose();
            inside += surface.contains(p);
        }
        EXPECT_GT(inside, 1000);
    }
}

TEST(SupportSurface, ClockwiseInputIsStoredCounterClockwise)
{
    const SupportSurface l(lShape().colwise().reverse(), 0.0);
    EXPECT_GT(signedArea(l.vertices()), 0.0);
    EXPECT_TRUE(l.contains({0.5, 1.5}));
}

TEST(SupportSurface, EarClippingCoversTheArea)
{
    const SupportSurface l(lShape(), 0.0);
    double area = 0.0;
    for (const auto &t : l.triangles())
    {
        Polygon2 tri(3, 2);
        tri << l.vertices().row(t[0]), l.vertices().row(t[1]), l.vertices().row(t[2]);
        EXPECT_GT(signedArea(tri), 0.0);
        area += signedArea(tri);
    }
    EXPECT_NEAR(area, l.area(), 1e-12);
}

TEST(SupportSurface, ClosestEdgeAndSignedDistance)
{
    const SupportSurface l(lShape(), 0.0);
    const EdgeQuery query = l.closestEdge({1.9, 0.5});
    EXPECT_NEAR(query.distance, 0.1, 1e-12);
    EXPECT_TRUE(query.outwardNormal.isApprox(Eigen::Vector2d(1, 0)));
    EXPECT_NEAR(l.signedDistance({1.9, 0.5}), 0.1, 1e-12);
    EXPECT_NEAR(l.signedDistance({2.2, 0.5}), -0.2, 1e-12);
}

TEST(SupportSurface, RejectsBadPolygons)
{
    Polygon2 two(2, 2);
    two << 0, 0, 1, 0;
    EXPECT_THROW(SupportSurface(two, 0.0), std::invalid_argument);
    Polygon2 bowtie(4, 2);
    bowtie << 0, 0, 1, 1, 1, 0, 0, 1;
    try
    {
        SupportSurface surface(bowtie, 0.0);
        FAIL() << "a bow-tie polygon was accepted";
    }
    catch (const std::invalid_argument &error)
    {
        EXPECT_NE(std::string(error.what()).find("self-intersecting"), std::string::npos);
    }
    Polygon2 collinear(3, 2);
    collinear << 0, 0, 1, 0, 2, 0;
    EXPECT_THROW(SupportSurface(collinear, 0.0), std::invalid_argument);
    Polygon2 nan = lShape();
    nan(2, 1) = std::nan("");
    EXPECT_THROW(SupportSurface(nan, 0.0), std::invalid_argument);
}

namespace
{
    Polygon2 circle(double radius, int vertices)
    {
        Polygon2 v(vertices, 2);
        for (int i = 0; i < vertices; ++i)
            v.row(i) << 0.5 + radius * std::cos(2 * M_PI * i / vertices), radius * std::sin(2 * M_PI * i / vertices);
        return v;
    }

    std::string rejection(const Polygon2 &vertices)
    {
        try
        {
            SupportSurface surface(vertices, 0.0);
        }
        catch (const std::invalid_argument &error)
        {
            return error.what();
        }
        return "";
    }
}  // namespace

// The crossing test's turns are judged relative to their size: a fixed epsilon called the turns of a
// fine circle's 3 micrometre edges collinear and the circle "self-intersecting: edge 0 crosses edge 2".
TEST(SupportSurface, AcceptsAFineCircleAtAnyScaleAndFindsATinyCrossingInIt)
{
    for (const double radius : {0.005, 0.2, 5.0})
        EXPECT_EQ(rejection(circle(radius, SupportSurface::kMaxVertices)), "") << "radius " << radius;
    Polygon2 crossed = circle(0.005, SupportSurface::kMaxVertices);
    crossed.row(5000).swap(crossed.row(5001));  // a bow-tie 3 micrometres wide
    EXPECT_NE(rejection(crossed).find("self-intersecting: edge 4999 crosses edge 5001"), std::string::npos)
        << rejection(crossed);
}

TEST(SupportSurface, RefusesMoreVerticesThanItsBound)
{
    EXPECT_NE(rejection(circle(0.2, SupportSurface::kMaxVertices + 1)).find("at most 10000"), std::string::npos);
}

TEST(ContactFrame, RotationHasTheRequestedAngles)
{
    for (double yaw : {-2.5, -0.3, 0.0, 1.0, 3.0})
        for (double pitch : {0.2, 1.0, M_PI / 2 - 1e-3})
        {
            const Eigen::Matrix3d r = contactRotation(yaw, pitch);
            EXPECT_TRUE((r.transpose() * r).isIdentity(1e-12));
            EXPECT_NEAR(r.col(0).cross(r.col(1)).dot(r.col(2)), 1.0, 1e-12);  // right-handed
            const ContactAngles angles = contactAngles(r);
            EXPECT_NEAR(angles.yaw, yaw, 1e-12);
            EXPECT_NEAR(angles.pitch, pitch, 1e-12);
            EXPECT_NEAR(angles.roll, 0.0, 1e-12);
            EXPECT_NEAR(-r.col(2).z(), std::sin(pitch), 1e-12);  // Z_F points into the surface
        }
}

// The area centroid follows the region the points cover, not where they are dense.
TEST(AreaCentroid, IsTheCentroidOfTheCoveredRegionWhateverTheDensity)
{
    // A 40 mm x 10 mm plate: its left half sampled every 0.25 mm, its right half every 1 mm (16 times
    // sparser). The mean leans 8.7 mm to the left; the area centroid is the plate's middle.
    std::vector<Eigen::Vector2d> points;
    for (int i = 0; i <= 80; ++i)
        for (int j = 0; j <= 40; ++j)
            points.emplace_back(i * 0.25e-3, j * 0.25e-3);
    for (int i = 21; i <= 40; ++i)
        for (int j = 0; j <= 10; ++j)
            points.emplace_back(i * 1e-3, j * 1e-3);
    Points2 cloud(static_cast<Eigen::Index>(points.size()), 2);
    for (std::size_t k = 0; k < points.size(); ++k)
        cloud.row(static_cast<Eigen::Index>(k)) = points[k].transpose();
    const Eigen::Vector2d middle(20e-3, 5e-3);
    EXPECT_LT((areaCentroid(cloud) - middle).norm(), 1e-9);
    EXPECT_GT((cloud.colwise().mean().transpose() - middle).norm(), 5e-3);
    // A gap of 10 spacings between two such plates is not part of the object.
    Points2 twoPlates(2 * cloud.rows(), 2);
    twoPlates << cloud, cloud.rowwise() + Eigen::RowVector2d(0.05, 0.0);
    EXPECT_LT((areaCentroid(twoPlates) - (middle + Eigen::Vector2d(0.025, 0.0))).norm(), 1e-9);
}

TEST(AreaCentroid, IsTheMeanWhenThePointsCoverNoArea)
{
    Points2 line(5, 2);
    line << 0, 0, 1, 1, 2, 2, 3, 3, 4, 4;
    EXPECT_TRUE(areaCentroid(line).isApprox(Eigen::Vector2d(2, 2)));
    Points2 bad(1, 2);
    bad << 0, std::nan("");
    EXPECT_THROW(areaCentroid(bad), std::invalid_argument);
    EXPECT_THROW(areaCentroid(Points2(0, 2)), std::invalid_argument);
}

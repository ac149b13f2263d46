#include "slideplan/area_centroid.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <libqhullcpp/Qhull.h>
#include <libqhullcpp/QhullError.h>
#include <libqhullcpp/QhullFacetList.h>
#include <libqhullcpp/QhullVertexSet.h>
#include <nanoflann.hpp>
#include <stdexcept>
#include <unordered_set>
#include <vector>

namespace slideplan
{
    namespace
    {
        constexpr std::size_t kThinAbove = 20000;  ///< points; larger clouds keep one point per cell
        constexpr double kThinCellM = 1e-3;
        constexpr int kNeighbours = 6;             ///< for the local spacing
        constexpr double kLongestEdgeFactor = 1.5; ///< a grid's diagonal (sqrt 2) stays, a gap of 2 goes

        /// The first point of each 1 mm cell, in the cloud's order.
        Points2 thinned(const Points2 &points)
        {
            std::unordered_set<std::uint64_t> seen;
            std::vector<Eigen::Index> kept;
            for (Eigen::Index i = 0; i < points.rows(); ++i)
            {
                const auto cx = static_cast<std::int64_t>(std::floor(points(i, 0) / kThinCellM));
                const auto cy = static_cast<std::int64_t>(std::floor(points(i, 1) / kThinCellM));
                const std::uint64_t key = (static_cast<std::uint64_t>(cx) << 32) ^ static_cast<std::uint32_t>(cy);
                if (seen.insert(key).second)
                    kept.push_back(i);
            }
            return points(kept, Eigen::all);
        }

        /// Each point's mean distance to its nearest neighbours (itself excluded).
        Eigen::VectorXd localSpacing(const Points2 &points)
        {
            using Tree = nanoflann::KDTreeEigenMatrixAdaptor<Points2, 2, nanoflann::metric_L2>;
            const Tree tree(2, std::cref(points), 10);
            const std::size_t k = std::min<std::size_t>(kNeighbours + 1, static_cast<std::size_t>(points.rows()));
            std::vector<Eigen::Index> index(k);
            std::vector<double> squared(k);
            Eigen::VectorXd spacing(points.rows());
            for (Eigen::Index i = 0; i < points.rows(); ++i)
            {
                const double query[2] = {points(i, 0), points(i, 1)};
                tree.query(query, k, index.data(), squared.data());
                double sum = 0.0;
                for (std::size_t j = 1; j < k; ++j)  // sorted: the first is the point itself (distance 0)
                    sum += std::sqrt(squared[j]);
                spacing(i) = k > 1 ? sum / static_cast<double>(k - 1) : 0.0;
            }
            return spacing;
        }
    }  // namespace

    Eigen::Vector2d areaCentroid(const Points2 &points)
    {
        return plateRegion(points).centroid;
    }

    PlateRegion plateRegion(const Points2 &input)
    {
        if (input.rows() == 0)
            throw std::invalid_argument("area centroid of no points");
        if (!input.allFinite())
            throw std::invalid_argument("area centroid: a point is not finite");
        const Points2 points = static_cast<std::size_t>(input.rows()) > kThinAbove ? thinned(input) : input;
        const Eigen::Vector2d mean = points.colwise().mean().transpose();
        if (points.rows() < 3)
            return {{}, 0.0, mean};

        std::vector<std::array<Eigen::Index, 3>> triangles;
        try
        {
            // The options of scipy.spatial.Delaunay (Qbb Qc Qz Q12, triangulated): Qz adds a point at
            // infinity for cocircular input such as grids, whose facets are the upper Delaunay ones skipped.
            orgQhull::Qhull qhull;
            qhull.runQhull("", 2, static_cast<int>(points.rows()), points.data(), "d Qbb Qc Qz Q12 Qt");
            for (const orgQhull::QhullFacet &facet : qhull.facetList())
            {
                if (facet.isUpperDelaunay())
                    continue;
                std::array<Eigen::Index, 3> triangle{};
                int corner = 0;
                for (const orgQhull::QhullVertex &vertex : facet.vertices())
                    if (corner < 3)
                        triangle[static_cast<std::size_t>(corner++)] = vertex.point().id();
                if (corner == 3)
                    triangles.push_back(triangle);
            }
        }
        catch (const orgQhull::QhullError &)
        {
            return {{}, 0.0, mean};  // all points on one line (or coincident): no area
        }

        const Eigen::VectorXd spacing = localSpacing(points);
        PlateRegion region;
        Eigen::Vector2d moment = Eigen::Vector2d::Zero();
        for (const auto &[a, b, c] : triangles)
        {
            const Eigen::Vector2d pa = points.row(a), pb = points.row(b), pc = points.row(c);
            const double longest = std::max({(pb - pa).norm(), (pc - pb).norm(), (pa - pc).norm()});
            if (longest > kLongestEdgeFactor * std::max({spacing(a), spacing(b), spacing(c)}))
                continue;
            const Eigen::Vector2d e1 = pb - pa, e2 = pc - pa;
            const double triangleArea = 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
            region.area += triangleArea;
            moment += triangleArea * (pa + pb + pc) / 3.0;
            region.triangles.push_back({pa, pb, pc});
        }
        region.centroid = region.area > 0.0 ? Eigen::Vector2d(moment / region.area) : mean;
        return region;
    }
}  // namespace slideplan

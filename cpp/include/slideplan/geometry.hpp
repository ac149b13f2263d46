/// \file geometry.hpp
/// The support surface Q of the paper (section IV-B): a simple planar polygon at a height.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

namespace slideplan
{
    /// Row-major list of 2-D polygon vertices, one vertex per row.
    using Polygon2 = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

    /// The edge of Q closest to a point, as used by pair validation (paper IV-C.1, Fig. 5).
    struct EdgeQuery
    {
        int edge{-1};                    ///< index i of edge (e_i, e_{i+1})
        double distance{0.0};            ///< unsigned distance from the point to the edge segment
        Eigen::Vector2d closest;         ///< closest point on the edge
        Eigen::Vector2d outwardNormal;   ///< unit normal of the edge pointing out of Q
    };

    /// Support surface Q = (e_1, ..., e_ns) at height z_table (paper IV-B). Any simple polygon,
    /// convex or not, either winding; stored counter-clockwise.
    class SupportSurface
    {
    public:
        /// Most vertices accepted: ear clipping (the table's collision triangles) is quadratic, and every
        /// contains() and closestEdge() visits each edge. A table outline needs far fewer.
        static constexpr int kMaxVertices = 10000;

        /// \throws std::invalid_argument if there are fewer than 3 or more than kMaxVertices vertices, a
        ///         vertex is not finite, the polygon is self-intersecting or its area is (nearly) zero.
        SupportSurface(const Polygon2 &vertices, double height);

        /// Point-in-polygon by the crossing-number test (the paper's [27]).
        bool contains(const Eigen::Vector2d &point) const;

        /// Distance to the boundary, positive inside Q and negative outside.
        double signedDistance(const Eigen::Vector2d &point) const;

        /// Closest edge of Q to a point.
        EdgeQuery closestEdge(const Eigen::Vector2d &point) const;

        /// Triangles (vertex indices, counter-clockwise) covering Q, by ear clipping.
        const std::vector<std::array<int, 3>> &triangles() const { return triangles_; }

        bool isConvex() const { return convex_; }
        const Polygon2 &vertices() const { return vertices_; }
        double height() const { return height_; }
        double area() const { return area_; }
        int size() const { return static_cast<int>(vertices_.rows()); }

    private:
        /// The crossing-number test itself.
        bool crosses(const Eigen::Vector2d &point) const;

        Polygon2 vertices_;
        double height_;
        Eigen::Vector2d centre_;
        double innerRadius2_{0.0}, outerRadius2_{0.0};  ///< squared radii of the discs contains() settles at once
        double area_{0.0};
        bool convex_{false};
        std::vector<std::array<int, 3>> triangles_;
    };

    /// Signed area of a polygon (positive for counter-clockwise).
    double signedArea(const Polygon2 &vertices);

    /// Counter-clockwise convex hull (no collinear vertices); fewer than 3 points for a degenerate set.
    std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> points);

    /// True if `point` lies in the counter-clockwise convex polygon `hull` (boundary included).
    bool pointInConvex(const std::vector<Eigen::Vector2d> &hull, const Eigen::Vector2d &point);

    /// Signed distance of `point` inside the counter-clockwise convex polygon `hull` (negative outside;
    /// -infinity for a hull of fewer than 3 vertices, which bears nothing).
    double convexSignedDistance(const std::vector<Eigen::Vector2d> &hull, const Eigen::Vector2d &point);

}  // namespace slideplan

#include "slideplan/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace slideplan
{
    namespace
    {
        double cross(const Eigen::Vector2d &a, const Eigen::Vector2d &b)
        {
            return a.x() * b.y() - a.y() * b.x();
        }

        /// Sign of the turn a -> b -> c, 0 where rounding could decide it: Shewchuk's error bound of
        /// the double-precision determinant (Robust Predicates, 1997, orient2d's first stage), relative
        /// to the terms' size. A fixed epsilon called the turns of a fine circle's edges (1e-5 m) collinear.
        int orientation(const Eigen::Vector2d &a, const Eigen::Vector2d &b, const Eigen::Vector2d &c)
        {
            const double left = (a.x() - c.x()) * (b.y() - c.y()), right = (a.y() - c.y()) * (b.x() - c.x());
            const double value = left - right;
            const double bound = 3.3306690738754716e-16 * (std::abs(left) + std::abs(right));
            return value > bound ? 1 : (value < -bound ? -1 : 0);
        }

        bool onSegment(const Eigen::Vector2d &a, const Eigen::Vector2d &b, const Eigen::Vector2d &p)
        {
            return p.x() <= std::max(a.x(), b.x()) && p.x() >= std::min(a.x(), b.x()) &&
                   p.y() <= std::max(a.y(), b.y()) && p.y() >= std::min(a.y(), b.y());
        }

        bool segmentsIntersect(const Eigen::Vector2d &p1, const Eigen::Vector2d &p2, const Eigen::Vector2d &q1,
                               const Eigen::Vector2d &q2)
        {
            const int o1 = orientation(p1, p2, q1), o2 = orientation(p1, p2, q2);
            const int o3 = orientation(q1, q2, p1), o4 = orientation(q1, q2, p2);
            if (o1 * o2 < 0 && o3 * o4 < 0)  // proper crossing; a 0 (touching) is settled below
                return true;
            return (o1 == 0 && onSegment(p1, p2, q1)) || (o2 == 0 && onSegment(p1, p2, q2)) ||
                   (o3 == 0 && onSegment(q1, q2, p1)) || (o4 == 0 && onSegment(q1, q2, p2));
        }

        Eigen::Vector2d closestOnSegment(const Eigen::Vector2d &a, const Eigen::Vector2d &b, const Eigen::Vector2d &p)
        {
            const Eigen::Vector2d ab = b - a;
            const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
            return a + t * ab;
        }

        bool pointInTriangle(const Eigen::Vector2d &p, const Eigen::Vector2d &a, const Eigen::Vector2d &b,
                             const Eigen::Vector2d &c)
        {
            return cross(b - a, p - a) >= 0 && cross(c - b, p - b) >= 0 && cross(a - c, p - c) >= 0;
        }

        /// A pair of non-adjacent edges that meet, or (-1, -1). A sweep over x: only edges whose
        /// x-ranges overlap are tested, so a table outline of thousands of vertices costs milliseconds.
        std::pair<int, int> firstCrossing(const Polygon2 &v)
        {
            const int n = static_cast<int>(v.rows());
            const auto lowX = [&](int e) { return std::min(v(e, 0), v((e + 1) % n, 0)); };
            const auto highX = [&](int e) { return std::max(v(e, 0), v((e + 1) % n, 0)); };
            std::vector<int> order(n), active;
            for (int e = 0; e < n; ++e)
                order[e] = e;
            std::sort(order.begin(), order.end(), [&](int a, int b) { return lowX(a) < lowX(b); });
            for (int e : order)
            {
                active.erase(std::remove_if(active.begin(), active.end(), [&](int a) { return highX(a) < lowX(e); }),
                             active.end());
                const Eigen::Vector2d p1 = v.row(e), p2 = v.row((e + 1) % n);
                for (int a : active)
                {
                    const bool adjacent = std::abs(a - e) == 1 || std::abs(a - e) == n - 1;
                    if (!adjacent && segmentsIntersect(p1, p2, v.row(a), v.row((a + 1) % n)))
                        return {std::min(a, e), std::max(a, e)};
                }
                active.push_back(e);
            }
            return {-1, -1};
        }

        /// Ear clipping of a simple counter-clockwise polygon: O(n^2), fine for table outlines.
        std::vector<std::array<int, 3>> earClip(const Polygon2 &v)
        {
            std::vector<int> remaining(v.rows());
            for (int i = 0; i < v.rows(); ++i)
                remaining[i] = i;
            std::vector<std::array<int, 3>> triangles;
            while (remaining.size() > 3)
            {
                bool clipped = false;
                const int n = static_cast<int>(remaining.size());
                for (int k = 0; k < n && !clipped; ++k)
                {
                    const int ia = remaining[(k + n - 1) % n], ib = remaining[k], ic = remaining[(k + 1) % n];
                    const Eigen::Vector2d a = v.row(ia), b = v.row(ib), c = v.row(ic);
                    if (cross(b - a, c - b) <= 0)
                        continue;  // reflex or collinear vertex: not an ear
                    bool empty = true;
                    for (int other : remaining)
                        if (other != ia && other != ib && other != ic && pointInTriangle(v.row(other), a, b, c))
                        {
                            empty = false;
                            break;
                        }
                    if (!empty)
                        continue;
                    triangles.push_back({ia, ib, ic});
                    remaining.erase(remaining.begin() + k);
                    clipped = true;
                }
                if (!clipped)  // only collinear vertices left: drop one, it adds no area
                    remaining.erase(remaining.begin());
            }
            if (remaining.size() == 3)
                triangles.push_back({remaining[0], remaining[1], remaining[2]});
            return triangles;
        }
    }  // namespace

    double signedArea(const Polygon2 &vertices)
    {
        double twiceArea = 0.0;
        const int n = static_cast<int>(vertices.rows());
        for (int i = 0; i < n; ++i)
            twiceArea += cross(vertices.row(i), vertices.row((i + 1) % n));
        return 0.5 * twiceArea;
    }

    SupportSurface::SupportSurface(const Polygon2 &vertices, double height) : vertices_(vertices), height_(height)
    {
        const int n = static_cast<int>(vertices_.rows());
        if (n < 3)
            throw std::invalid_argument("support polygon needs at least 3 vertices, got " + std::to_string(n));
        if (!vertices_.allFinite())
            throw std::invalid_argument("support polygon has a NaN or infinite vertex");
        if (!std::isfinite(height_))
            throw std::invalid_argument("support surface height is not finite");
        if (n > kMaxVertices)
            throw std::invalid_argument("support polygon has " + std::to_string(n) + " vertices, at most " +
                                        std::to_string(kMaxVertices) + " (simplify the outline)");
        const auto [i, j] = firstCrossing(vertices_);
        if (i >= 0)
        {
            std::ostringstream msg;
            msg << "support polygon is self-intersecting: edge " << i << " crosses edge " << j;
            throw std::invalid_argument(msg.str());
        }
        double area = signedArea(vertices_);
        if (std::abs(area) < 1e-8)
            throw std::invalid_argument("support polygon is degenerate (zero area)");
        if (area < 0)
        {
            vertices_ = vertices_.colwise().reverse().eval();
            area = -area;
        }
        area_ = area;
        convex_ = true;
        for (int i = 0; i < n; ++i)
            if (orientation(vertices_.row(i), vertices_.row((i + 1) % n), vertices_.row((i + 2) % n)) < 0)
                convex_ = false;
        triangles_ = earClip(vertices_);

        // Discs around the vertex mean that settle most points without the crossing test: inside the
        // distance to the nearest edge (if the mean is inside Q), outside the farthest vertex. Shrunk and
        // grown by 1e-9 so that rounding never decides against the exact test.
        centre_ = vertices_.colwise().mean().transpose();
        for (int i = 0; i < n; ++i)
            outerRadius2_ = std::max(outerRadius2_, (vertices_.row(i).transpose() - centre_).squaredNorm());
        outerRadius2_ *= 1.0 + 1e-9;
        if (crosses(centre_))
            innerRadius2_ = std::pow(closestEdge(centre_).distance, 2) * (1.0 - 1e-9);
    }

    bool SupportSurface::contains(const Eigen::Vector2d &point) const
    {
        const double radius2 = (point - centre_).squaredNorm();
        if (radius2 < innerRadius2_)
            return true;
        if (radius2 > outerRadius2_)
            return false;
        return crosses(point);
    }

    bool SupportSurface::crosses(const Eigen::Vector2d &point) const
    {
        bool inside = false;
        const int n = size();
        for (int i = 0, j = n - 1; i < n; j = i++)
        {
            const double xi = vertices_(i, 0), yi = vertices_(i, 1), xj = vertices_(j, 0), yj = vertices_(j, 1);
            if ((yi > point.y()) != (yj > point.y()) && point.x() < (xj - xi) * (point.y() - yi) / (yj - yi) + xi)
                inside = !inside;
        }
        return inside;
    }

    EdgeQuery SupportSurface::closestEdge(const Eigen::Vector2d &point) const
    {
        EdgeQuery best;
        best.distance = std::numeric_limits<double>::infinity();
        const int n = size();
        for (int i = 0; i < n; ++i)
        {
            const Eigen::Vector2d a = vertices_.row(i), b = vertices_.row((i + 1) % n);
            const Eigen::Vector2d closest = closestOnSegment(a, b, point);
            const double distance = (point - closest).norm();
            if (distance < best.distance)
            {
                best.edge = i;
                best.distance = distance;
                best.closest = closest;
                const Eigen::Vector2d edge = (b - a).normalized();
                best.outwardNormal = Eigen::Vector2d(edge.y(), -edge.x());  // right of a CCW edge is outside
            }
        }
        return best;
    }

    double SupportSurface::signedDistance(const Eigen::Vector2d &point) const
    {
        const double distance = closestEdge(point).distance;
        return contains(point) ? distance : -distance;
    }

    // Andrew's monotone chain.
    std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> points)
    {
        std::sort(points.begin(), points.end(), [](const auto &a, const auto &b) {
            return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
        });
        if (points.size() < 3)
            return points;
        std::vector<Eigen::Vector2d> hull(2 * points.size());
        std::size_t k = 0;
        const auto turn = [&](const Eigen::Vector2d &a, const Eigen::Vector2d &b, const Eigen::Vector2d &c) {
            return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
        };
        for (const auto &p : points)
        {
            while (k >= 2 && turn(hull[k - 2], hull[k - 1], p) <= 0)
                --k;
            hull[k++] = p;
        }
        for (std::size_t i = points.size() - 1, lower = k + 1; i-- > 0;)
        {
            while (k >= lower && turn(hull[k - 2], hull[k - 1], points[i]) <= 0)
                --k;
            hull[k++] = points[i];
        }
        hull.resize(k - 1);
        return hull;
    }

    bool pointInConvex(const std::vector<Eigen::Vector2d> &hull, const Eigen::Vector2d &point)
    {
        if (hull.size() < 3)
            return false;
        for (std::size_t i = 0; i < hull.size(); ++i)
        {
            const Eigen::Vector2d edge = hull[(i + 1) % hull.size()] - hull[i], offset = point - hull[i];
            if (edge.x() * offset.y() - edge.y() * offset.x() < 0.0)
                return false;
        }
        return true;
    }

    double convexSignedDistance(const std::vector<Eigen::Vector2d> &hull, const Eigen::Vector2d &point)
    {
        if (hull.size() < 3)
            return -std::numeric_limits<double>::infinity();
        double nearest = std::numeric_limits<double>::infinity();
        for (std::size_t i = 0; i < hull.size(); ++i)
        {
            const Eigen::Vector2d a = hull[i], edge = hull[(i + 1) % hull.size()] - a;
            const double t = std::clamp((point - a).dot(edge) / edge.squaredNorm(), 0.0, 1.0);
            nearest = std::min(nearest, (point - (a + t * edge)).norm());
        }
        return pointInConvex(hull, point) ? nearest : -nearest;
    }

}  // namespace slideplan

#include "slideplan/hold_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace slideplan
{
    namespace
    {
        /// Sutherland-Hodgman: the part of a convex polygon where normal . p <= limit.
        std::vector<Eigen::Vector2d> clipped(const std::vector<Eigen::Vector2d> &polygon, const Eigen::Vector2d &normal,
                                             double limit)
        {
            std::vector<Eigen::Vector2d> result;
            for (std::size_t i = 0; i < polygon.size(); ++i)
            {
                const Eigen::Vector2d &a = polygon[i], &b = polygon[(i + 1) % polygon.size()];
                const double da = normal.dot(a) - limit, db = normal.dot(b) - limit;
                if (da <= 0.0)
                    result.push_back(a);
                if ((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0))
                    result.push_back(a + (b - a) * (da / (da - db)));
            }
            return result;
        }
    }  // namespace

    HoldEstimate estimateHold(const PlateRegion &plate, const Eigen::Vector2d &com, double thickness,
                              const Eigen::Vector2d &grasp, double beyond, const Eigen::Vector2d &outward,
                              const PlannerParams &params)
    {
        constexpr double kGravity = 9.81;  // m/s^2
        const Eigen::Vector2d along(-outward.y(), outward.x());
        HoldEstimate estimate;
        estimate.mass = params.objectDensity * thickness * plate.area;
        // The patch: each triangle of the plate clipped to the pads' rectangle, in coordinates about H_g.
        std::vector<std::vector<Eigen::Vector2d>> patch;
        Eigen::Vector2d moment = Eigen::Vector2d::Zero();
        for (const auto &triangle : plate.triangles)
        {
            std::vector<Eigen::Vector2d> part{triangle[0] - grasp, triangle[1] - grasp, triangle[2] - grasp};
            for (const auto &[axis, half] : {std::pair{along, 0.5 * params.padWidth}, std::pair{outward, 0.5 * params.padLength}})
            {
                part = clipped(part, axis, half);
                part = clipped(part, -axis, half);
            }
            part = clipped(part, -outward, beyond);  // nothing over the table
            double area = 0.0;
            for (std::size_t i = 1; i + 1 < part.size(); ++i)  // a fan: the clipped triangle stays convex
            {
                const Eigen::Vector2d e1 = part[i] - part[0], e2 = part[i + 1] - part[0];
                const double piece = 0.5 * std::abs(e1.x() * e2.y() - e1.y() * e2.x());
                area += piece;
                moment += piece * (part[0] + part[i] + part[i + 1]) / 3.0;
            }
            if (area > 0.0)
            {
                estimate.patchArea += area;
                patch.push_back(std::move(part));
            }
        }
        if (estimate.patchArea <= 0.0)
            return estimate;  // the pads close on air
        const Eigen::Vector2d lever = com - (grasp + moment / estimate.patchArea);
        estimate.lever = lever.norm();
        // The patch's length along the lever (any direction when the centre of mass is in the pinch).
        const Eigen::Vector2d direction = estimate.lever > 1e-9 ? Eigen::Vector2d(lever / estimate.lever) : along;
        double low = std::numeric_limits<double>::infinity(), high = -low;
        for (const auto &part : patch)
            for (const Eigen::Vector2d &corner : part)
            {
                low = std::min(low, corner.dot(direction));
                high = std::max(high, corner.dot(direction));
            }
        estimate.patchLength = high - low;
        estimate.demand = estimate.mass * kGravity * estimate.lever;
        estimate.capacity = params.gripForce * estimate.patchLength;
        estimate.holds = estimate.demand <= estimate.capacity;
        return estimate;
    }
}  // namespace slideplan

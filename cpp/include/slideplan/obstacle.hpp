/// \file obstacle.hpp
/// Static obstacles on or above the table (clutter, the paper's future work): boxes, vertical
/// cylinders (mugs, cans) and vertical prisms (other thin objects, over their convex footprint). The
/// arm avoids them, and the sliding object must not overlap their footprints.
#pragma once

#include <Eigen/Geometry>
#include <vector>

namespace slideplan
{
    struct Obstacle
    {
        enum class Shape
        {
            Box,       ///< size = full extents in the pose's frame
            Cylinder,  ///< size = (radius, height, 0), axis along the pose's z
            Prism      ///< polygon (world xy, convex, counter-clockwise) between pose.z -+ size.z / 2
        };
        Shape shape{Shape::Box};
        Eigen::Isometry3d pose{Eigen::Isometry3d::Identity()};  ///< centre; boxes and cylinders stand upright
        Eigen::Vector3d size{Eigen::Vector3d::Zero()};
        std::vector<Eigen::Vector2d> polygon;  ///< Prism only

        double height() const { return shape == Shape::Cylinder ? size.y() : size.z(); }
        double bottom() const { return pose.translation().z() - 0.5 * height(); }
        /// Whether the point (x, y) lies in the obstacle's vertical projection on the table.
        bool covers(const Eigen::Vector2d &point) const;
        /// \throws std::invalid_argument naming obstacle `index` for a non-finite or non-positive size, a
        ///         tilted box or cylinder, or a prism polygon that is not convex and counter-clockwise.
        void validate(std::size_t index) const;
    };

}  // namespace slideplan

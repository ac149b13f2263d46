/// \file object_motion.hpp
/// Eq. 2: kappa_t = Gamma(phi_t) inv(Gamma(phi_s)) kappa_s, restricted to SE(2) because the object
/// stays flat on the table: the planar motion (x, y, yaw of X_F) of the contact frame.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace slideplan
{
    /// A planar rigid motion: p' = R(yaw) p + (x, y).
    struct PlanarMotion
    {
        double x{0.0}, y{0.0}, yaw{0.0};
        Eigen::Vector2d apply(const Eigen::Vector2d &point) const;
        /// The same motion as a transform: for many points, one sine and cosine instead of one per point.
        Eigen::Isometry2d transform() const;
    };

    /// Eq. 2: the object motion that carries the contact frame from `start` to `goal` (world poses of F).
    PlanarMotion objectMotion(const Eigen::Isometry3d &start, const Eigen::Isometry3d &goal);

}  // namespace slideplan

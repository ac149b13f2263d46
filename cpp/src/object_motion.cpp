#include "slideplan/object_motion.hpp"

#include <cmath>

namespace slideplan
{
    Eigen::Vector2d PlanarMotion::apply(const Eigen::Vector2d &point) const
    {
        return Eigen::Rotation2Dd(yaw) * point + Eigen::Vector2d(x, y);
    }

    Eigen::Isometry2d PlanarMotion::transform() const
    {
        Eigen::Isometry2d result = Eigen::Isometry2d::Identity();
        result.linear() = Eigen::Rotation2Dd(yaw).toRotationMatrix();
        result.translation() << x, y;
        return result;
    }

    PlanarMotion objectMotion(const Eigen::Isometry3d &start, const Eigen::Isometry3d &goal)
    {
        const auto heading = [](const Eigen::Isometry3d &frame) {
            return std::atan2(frame.linear()(1, 0), frame.linear()(0, 0));  // yaw of X_F
        };
        PlanarMotion motion;
        motion.yaw = std::remainder(heading(goal) - heading(start), 2.0 * M_PI);
        const Eigen::Vector2d offset =
            goal.translation().head<2>() - Eigen::Rotation2Dd(motion.yaw) * start.translation().head<2>();
        motion.x = offset.x();
        motion.y = offset.y();
        return motion;
    }

}  // namespace slideplan

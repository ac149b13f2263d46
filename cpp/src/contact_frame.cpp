#include "slideplan/contact_frame.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace slideplan
{
    Eigen::Matrix3d contactRotation(double yaw, double pitch)
    {
        const Eigen::Vector3d xAxis(std::cos(yaw), std::sin(yaw), 0.0);
        const Eigen::Vector3d horizontal(-std::sin(yaw), std::cos(yaw), 0.0);  // n_up x X_F
        const Eigen::Vector3d zAxis = std::cos(pitch) * horizontal - std::sin(pitch) * Eigen::Vector3d::UnitZ();
        Eigen::Matrix3d rotation;
        rotation.col(0) = xAxis;
        rotation.col(1) = zAxis.cross(xAxis);
        rotation.col(2) = zAxis;
        return rotation;
    }

    ContactAngles contactAngles(const Eigen::Matrix3d &rotation)
    {
        const Eigen::Vector3d xAxis = rotation.col(0), zAxis = rotation.col(2);
        ContactAngles angles;
        angles.yaw = std::atan2(xAxis.y(), xAxis.x());
        angles.pitch = std::asin(std::clamp(-zAxis.z(), -1.0, 1.0));
        angles.roll = std::asin(std::clamp(xAxis.z(), -1.0, 1.0));
        return angles;
    }

    IkOptions contactIkOptions(const RobotModel &robot)
    {
        IkOptions options;
        if (robot.dof() < 6)
        {
            options.rotationTolerance.z() = M_PI;
            options.worldAxes = true;
        }
        return options;
    }

}  // namespace slideplan

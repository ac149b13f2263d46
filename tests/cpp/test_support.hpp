// Shared fixtures of the C++ tests: the bundled robot and a square table.
#pragma once

#include "slideplan/geometry.hpp"
#include "slideplan/robot_model.hpp"

#include <memory>
#include <string>

namespace slideplan::testing
{
    inline std::string robotPath()
    {
        return std::string(SLIDEPLAN_DATA_DIR) + "/robots/wam_t42.urdf";
    }

    /// The default mount: the WAM's base frame (the shoulder) 0.30 m above the table top.
    inline Eigen::Isometry3d defaultMount()
    {
        Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
        mount.translation().z() = 0.30;
        return mount;
    }

    inline std::shared_ptr<RobotModel> wamT42(const std::string &tip = "fingertip_contact",
                                              const Eigen::Isometry3d &mount = defaultMount())
    {
        return std::make_shared<RobotModel>(RobotModel::fromFile(robotPath(), tip, mount));
    }

    inline SupportSurface squareTable()
    {
        Polygon2 square(4, 2);
        square << 0.35, -0.25, 0.85, -0.25, 0.85, 0.25, 0.35, 0.25;
        return SupportSurface(square, 0.0);
    }
}  // namespace slideplan::testing

// Shared fixtures of the C++ tests: the bundled robot and a square table.
#pragma once

#include "slideplan/geometry.hpp"
#include "slideplan/robot_model.hpp"

#include <memory>
#include <ompl/util/Console.h>
#include <string>

namespace slideplan::testing
{
    /// Debian's OMPL logs at debug level by default (docs/design.md 7): keep test output readable.
    inline const bool kQuietOmpl = (ompl::msg::setLogLevel(ompl::msg::LOG_WARN), true);

    inline std::string robotPath()
    {
        return std::string(SLIDEPLAN_DATA_DIR) + "/robots/wam_t42.urdf";
    }

    /// The default mount: the WAM's base frame (the shoulder) 0.20 m above the table top.
    inline Eigen::Isometry3d defaultMount()
    {
        Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
        mount.translation().z() = 0.20;
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
        square << 0.30, -0.20, 0.70, -0.20, 0.70, 0.20, 0.30, 0.20;
        return SupportSurface(square, 0.0);
    }
}  // namespace slideplan::testing

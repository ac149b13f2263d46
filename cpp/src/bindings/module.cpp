#include "bindings.hpp"

#include <ompl/util/Console.h>
#include <stdexcept>

namespace py = pybind11;

namespace slideplan::bindings
{
    Eigen::Isometry3d toIsometry(const Eigen::Matrix4d &matrix)
    {
        if (!matrix.allFinite() || !matrix.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)) ||
            !(matrix.topLeftCorner<3, 3>().transpose() * matrix.topLeftCorner<3, 3>()).isIdentity(1e-6))
            throw std::invalid_argument("pose must be a finite 4x4 homogeneous matrix with a rotation block");
        Eigen::Isometry3d pose;
        pose.matrix() = matrix;
        return pose;
    }
}  // namespace slideplan::bindings

PYBIND11_MODULE(_core, module)
{
    module.doc() = "slideplan C++ core: robot kinematics, collision world, geometry and the planner.";
    // Debian's OMPL logs at debug level to stdout by default (docs/design.md 7).
    ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
    module.def(
        "set_ompl_log_level", [](int level) { ompl::msg::setLogLevel(static_cast<ompl::msg::LogLevel>(level)); },
        py::arg("level"), "Set OMPL's log level: 0 dev2, 1 dev1, 2 debug, 3 info, 4 warn, 5 error, 6 none.");
    slideplan::bindings::bindGeometry(module);
    slideplan::bindings::bindRobot(module);
    slideplan::bindings::bindCollision(module);
    slideplan::bindings::bindPlanner(module);
}

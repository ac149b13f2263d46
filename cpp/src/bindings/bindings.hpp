/// \file bindings.hpp
/// Registration functions of the pybind11 module `slideplan._core`, one per area.
#pragma once

#include <Eigen/Geometry>
#include <pybind11/pybind11.h>

namespace slideplan::bindings
{
    void bindGeometry(pybind11::module_ &module);
    void bindRobot(pybind11::module_ &module);
    void bindCollision(pybind11::module_ &module);
    void bindPlanner(pybind11::module_ &module);

    /// 4x4 homogeneous matrices on the Python side, Isometry3d on the C++ side.
    Eigen::Isometry3d toIsometry(const Eigen::Matrix4d &matrix);
}  // namespace slideplan::bindings

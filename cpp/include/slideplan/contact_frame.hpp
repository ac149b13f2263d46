/// \file contact_frame.hpp
/// Fingertip contact frame F of Fig. 4 and docs/design.md section 3: X_F is the contact line and lies in
/// the surface plane (roll 0), Z_F points into the object, pitch beta is the angle between Z_F and
/// the surface plane (-Z_F . n_up = sin(beta)), yaw alpha is the heading of X_F about n_up.
#pragma once

#include <Eigen/Core>

namespace slideplan
{
    /// r(alpha, beta) of Eq. 3 and Eq. 4: the fingertip orientation in contact with a horizontal surface.
    Eigen::Matrix3d contactRotation(double yaw, double pitch);

    /// Angles of an arbitrary fingertip orientation relative to the horizontal surface.
    struct ContactAngles
    {
        double yaw;    ///< alpha: heading of X_F about the surface normal
        double pitch;  ///< beta: asin(-Z_F . n_up)
        double roll;   ///< asin(X_F . n_up): tilt of the contact line out of the surface plane
    };

    ContactAngles contactAngles(const Eigen::Matrix3d &rotation);

}  // namespace slideplan

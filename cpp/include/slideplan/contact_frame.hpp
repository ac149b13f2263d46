/// \file contact_frame.hpp
/// Fingertip contact frame F of Fig. 4 and docs/design.md section 3: X_F is the contact line and lies in
/// the surface plane (roll 0), Z_F points into the object, pitch beta is the angle between Z_F and
/// the surface plane (-Z_F . n_up = sin(beta)), yaw alpha is the heading of X_F about n_up.
#pragma once

#include "slideplan/robot_model.hpp"

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

    /// IK options for a contact pose r(alpha, beta) at a point: Eq. 3 constrains the depth, roll and
    /// pitch, and leaves the yaw free, which an arm with fewer than six joints cannot also choose: its
    /// IK takes the yaw its posture gives. Six or more joints reach the yaw asked for.
    IkOptions contactIkOptions(const RobotModel &robot);

}  // namespace slideplan

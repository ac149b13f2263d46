/// \file timing.hpp
/// Time-optimal parameterization of a dense joint path from rest to rest (TOPP-RA, Pham & Pham 2018)
/// under joint velocity and acceleration limits and a cap on the fingertip speed: the `timing` block of
/// plan JSON /2 (docs/timing.md). Beyond the paper, which stops at the geometric path.
///
/// The path is interpolated by natural cubic splines over its joint-space arc length. The velocity
/// limits bound x = s'^2 at each grid point, the acceleration limits (collocated) bound u = s'' given x,
/// and TOPP-RA's backward pass computes the sets of x from which rest at the end is reachable; its
/// forward pass then takes the largest u at every step. The limits hold at the grid points; a final check
/// by finite differences between waypoints slows the profile down uniformly wherever they do not.
#pragma once

#include "slideplan/robot_model.hpp"

#include <Eigen/Core>
#include <vector>

namespace slideplan
{
    struct TimingLimits
    {
        Eigen::VectorXd jointVelocity;      ///< per joint (rad/s), > 0
        Eigen::VectorXd jointAcceleration;  ///< per joint (rad/s^2), > 0
        double fingertipSpeed{0.05};        ///< where capped (m/s), > 0
    };

    /// One segment's profile, one row per waypoint, from rest at t = 0 to rest.
    struct TimedPath
    {
        Eigen::VectorXd timeFromStart;
        Eigen::MatrixXd velocities, accelerations;
    };

    /// Time a path (M x dof waypoints) whose fingertip passes `tips` (M x 3); `capped[i]` says where the
    /// fingertip cap applies (an interval is capped when either end is).
    /// \throws std::invalid_argument on malformed input or limits, std::runtime_error when no rest-to-rest
    ///         parameterization exists.
    TimedPath timePath(const Eigen::MatrixXd &path, const Eigen::MatrixXd &tips, const std::vector<bool> &capped,
                       const TimingLimits &limits);

    /// Approach waypoints with the fingertip less than this above the object's top are capped too (m): nothing may
    /// hit the table or the object fast.
    constexpr double kNearTableM = 0.02;

    /// The two timed segments of a plan: the slide (capped throughout: the object must follow the finger, Eq. 2)
    /// and the approach to the grasp (capped within kNearTableM of the object's top).
    struct PlanTiming
    {
        TimedPath trajectory, approach;
    };

    /// Time a plan's slide (`trajectory`, M x dof, its fingertip at `trajectoryTips`, M x 3) and `approach`
    /// (K x dof; its fingertip positions from `robot`'s forward kinematics), the object's top at `objectTopZ`.
    PlanTiming timePlan(const RobotModel &robot, const Eigen::MatrixXd &trajectory, const Eigen::MatrixXd &trajectoryTips,
                        const Eigen::MatrixXd &approach, double objectTopZ, const TimingLimits &limits);
}  // namespace slideplan

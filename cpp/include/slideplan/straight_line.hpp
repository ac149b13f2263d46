/// \file straight_line.hpp
/// A frame of the arm moved along a straight line a centimetre at a time: the lift after the grasp (the
/// planner's lift check, GraspMap) and the execution's straight moves (slideplan.motions: the lift, the
/// fingertip up off the object and aside to look), one computation for both.
#pragma once

#include "slideplan/robot_model.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace slideplan
{
    constexpr double kLiftStep = 0.01;      ///< m: the line is solved at least this often
    constexpr double kLiftJointStep = 0.3;  ///< rad: a step turning a joint further has left the arm's branch

    /// The configurations moving the frame `link` x `frame` (the tip frame when `link` is empty) from
    /// `start` (its pose at `q`, or the pose asked of it there) by `offset` (m, world frame) in a straight
    /// line, its orientation kept: `q`, then one per step of at most kLiftStep, each by IK (`options`, a
    /// generator seeded `rngSeed` afresh for each step) seeded by the one before. std::nullopt where a step
    /// has no IK or turns a joint more than kLiftJointStep: one IK for the whole move may land on another
    /// branch of the arm (a WAM grasp with its wrist at its limit "lifted" by turning it a full turn).
    /// \throws std::invalid_argument if `link` is not a link moved by every chain joint.
    std::optional<std::vector<Eigen::VectorXd>> straightLine(const RobotModel &robot, const Eigen::VectorXd &q,
                                                             const Eigen::Isometry3d &start, const Eigen::Vector3d &offset,
                                                             const IkOptions &options, std::uint64_t rngSeed = 0,
                                                             const std::string &link = "",
                                                             const Eigen::Isometry3d &frame = Eigen::Isometry3d::Identity());
}  // namespace slideplan

/// \file paired_goal.hpp
/// Beyond the paper (params.pairedGoals): a goal contact frame drawn for a given start root, so that
/// Eq. 2 carries the object from where it lies to a pose worth grasping. Algorithm 1 draws goal roots
/// independently of the start roots; then few (start, goal) root pairs leave the object overhanging
/// by u* with its centre of mass on the table, and far fewer where a side grasp is reachable (the
/// triangle table's far edges).
#pragma once

#include "slideplan/pair_validator.hpp"
#include "slideplan/params.hpp"
#include "slideplan/task.hpp"

#include <Eigen/Geometry>
#include <random>

namespace slideplan
{
    /// Draw an object pose overhanging an edge of Q (edge by length, the object turned by at most
    /// params.maxObjectYaw, its overhang between u* and what keeps the centre of mass comMargin
    /// inside), keep it if the cheap part of IsPairValid accepts it, the start contact lands in the
    /// goal band P_g (Eq. 4), the turn is at most params.maxYawRate times the straight slide there, and
    /// (params.graspMap) a side grasp is reachable on that stretch of edge
    /// (the grasp map) with the hand clear of the table there, and return the contact frame there:
    /// `startTip` moved by that pose, at a depth from [dz_min, dz_max]. False if none of 48 draws was
    /// accepted.
    bool pairedGoalTarget(const SlidingTask &task, const PlannerParams &params, const PairValidator &validator,
                          const Eigen::Isometry3d &startTip, std::mt19937_64 &rng,
                          Eigen::Isometry3d &target);

}  // namespace slideplan

/// \file ompl_peer.hpp
/// A peer for the planning benchmark: OMPL's own constrained planning stack
/// (ompl::base::ProjectedStateSpace + ompl::geometric::RRTConnect) on our constraint and validity,
/// connecting a given valid start/goal pair, so that ConstrainedExtend is compared with OMPL's on
/// the same problems.
#pragma once

#include "slideplan/params.hpp"
#include "slideplan/task.hpp"

#include <ompl/base/PlannerTerminationCondition.h>

namespace slideplan
{
    struct PeerResult
    {
        bool solved{false};
        double seconds{0.0};      ///< wall time of the connection (setup included)
        std::size_t states{0};    ///< states of the solution path
    };

    /// Connect `start` to `goal` (both valid sliding states) with RRTConnect on a ProjectedStateSpace
    /// over SlidingConstraint (our projection), states checked by SlidingValidity, the step (delta)
    /// set to params.maxJointStep.
    PeerResult connectWithOmplProjection(std::shared_ptr<const SlidingTask> task, const PlannerParams &params,
                                         const Eigen::VectorXd &start, const Eigen::VectorXd &goal,
                                         const ompl::base::PlannerTerminationCondition &ptc);

}  // namespace slideplan

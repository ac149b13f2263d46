/// \file validity.hpp
/// State validity while sliding (paper IV-C.3): within joint limits, on the relaxed constraint,
/// fingertip inside Q (the object must not be pushed off the table), and collision-free with the
/// contacting finger allowed to penetrate table and object.
#pragma once

#include "slideplan/collision.hpp"
#include "slideplan/constraint.hpp"
#include "slideplan/task.hpp"

#include <ompl/base/StateValidityChecker.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>

namespace slideplan
{
    /// The arm's joint space for OMPL: one real dimension per chain joint, bounded by its limits.
    std::shared_ptr<ompl::base::RealVectorStateSpace> jointSpace(const RobotModel &robot);

    class SlidingValidity : public ompl::base::StateValidityChecker
    {
    public:
        SlidingValidity(const ompl::base::SpaceInformationPtr &si, std::shared_ptr<const SlidingTask> task,
                        std::shared_ptr<const SlidingConstraint> constraint);

        bool isValid(const ompl::base::State *state) const override;

        /// The same check with the fingertip pose `tip = Gamma(q)` already known.
        bool isValid(const JointsRef &q, const Eigen::Isometry3d &tip) const;

        /// Why isValid(q, tip) is false, in words with the amounts (empty if it is true): a caller that hands
        /// the planner its own configuration must hear which joint, band or link is at fault, and by how much.
        std::string problem(const JointsRef &q, const Eigen::Isometry3d &tip) const;

        const SlidingTask &task() const { return *task_; }
        const SlidingConstraint &constraint() const { return *constraint_; }
        const CollisionWorld &world() const { return *world_; }

    private:
        std::shared_ptr<const SlidingTask> task_;
        std::shared_ptr<const SlidingConstraint> constraint_;
        std::unique_ptr<CollisionWorld> world_;
    };

}  // namespace slideplan

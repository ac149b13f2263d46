#include "slideplan/validity.hpp"

#include <ompl/base/SpaceInformation.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>

namespace slideplan
{
    std::shared_ptr<ompl::base::RealVectorStateSpace> jointSpace(const RobotModel &robot)
    {
        auto space = std::make_shared<ompl::base::RealVectorStateSpace>(robot.dof());
        ompl::base::RealVectorBounds bounds(robot.dof());
        for (unsigned i = 0; i < robot.dof(); ++i)
        {
            bounds.setLow(i, robot.lowerLimits()(i));
            bounds.setHigh(i, robot.upperLimits()(i));
        }
        space->setBounds(bounds);
        return space;
    }

    SlidingValidity::SlidingValidity(const ompl::base::SpaceInformationPtr &si, std::shared_ptr<const SlidingTask> task,
                                     std::shared_ptr<const SlidingConstraint> constraint)
      : ompl::base::StateValidityChecker(si)
      , task_(std::move(task))
      , constraint_(std::move(constraint))
      , world_(std::make_unique<CollisionWorld>(task_->robot, *task_->table, task_->obstacles, task_->contactLinks))
    {
    }

    bool SlidingValidity::isValid(const ompl::base::State *state) const
    {
        const auto *values = state->as<ompl::base::RealVectorStateSpace::StateType>()->values;
        const Eigen::Map<const Eigen::VectorXd> q(values, task_->robot->dof());
        return isValid(q, task_->robot->fk(q));
    }

    bool SlidingValidity::isValid(const JointsRef &q, const Eigen::Isometry3d &tip) const
    {
        return task_->robot->withinLimits(q) && constraint_->satisfied(tip) &&
               task_->table->contains(tip.translation().head<2>()) && world_->isValid(q, ContactMode::Sliding);
    }

}  // namespace slideplan

#include "slideplan/validity.hpp"

#include <ompl/base/SpaceInformation.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>

#include <sstream>

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

    std::string SlidingValidity::problem(const JointsRef &q, const Eigen::Isometry3d &tip) const
    {
        const RobotModel &robot = *task_->robot;
        std::ostringstream out;
        if (q.size() != robot.dof())
        {
            out << "has " << q.size() << " joints, the robot " << robot.dof();
            return out.str();
        }
        if (!robot.withinLimits(q))
            for (unsigned i = 0; i < robot.dof(); ++i)
                if (q(i) < robot.lowerLimits()(i) || q(i) > robot.upperLimits()(i))
                {
                    out << "joint " << robot.jointNames()[i] << " = " << q(i) << " is outside its limits ["
                        << robot.lowerLimits()(i) << ", " << robot.upperLimits()(i) << "]";
                    return out.str();
                }
        const Eigen::Vector3d residual = constraint_->residual(tip);
        if (residual.cwiseAbs().maxCoeff() > constraint_->getTolerance())
        {
            // The rows of constraint.hpp: depth band, roll, pitch band.
            out << "is off the sliding contact constraint (tolerance " << constraint_->getTolerance() << "): ";
            if (residual(0) != 0.0)
                out << "the fingertip is " << std::abs(residual(0)) << " m " << (residual(0) > 0.0 ? "above" : "below")
                    << " its depth band [dz_min, dz_max] under the object's top; ";
            if (residual(1) != 0.0)
                out << "its contact line leaves the table plane by " << std::asin(std::clamp(residual(1), -1.0, 1.0)) << " rad of roll; ";
            if (residual(2) != 0.0)
                out << "sin of its pitch is " << std::abs(residual(2)) << " outside sin([beta0 - delta_beta, beta0 + delta_beta]); ";
            std::string text = out.str();
            return text.substr(0, text.size() - 2);
        }
        if (!task_->table->contains(tip.translation().head<2>()))
        {
            out << "puts the fingertip at (" << tip.translation().x() << ", " << tip.translation().y() << "), off the table";
            return out.str();
        }
        if (const auto pairs = world_->collisions(q, ContactMode::Sliding); !pairs.empty())
        {
            out << "collides:";
            for (const auto &[a, b] : pairs)
                out << " " << a << " with " << b << ";";
            std::string text = out.str();
            return text.substr(0, text.size() - 1);
        }
        return "";
    }

}  // namespace slideplan

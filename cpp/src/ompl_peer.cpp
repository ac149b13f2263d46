#include "slideplan/ompl_peer.hpp"

#include "slideplan/constraint.hpp"
#include "slideplan/validity.hpp"

#include <chrono>
#include <ompl/base/ConstrainedSpaceInformation.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/base/spaces/constraint/ProjectedStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace slideplan
{
    PeerResult connectWithOmplProjection(std::shared_ptr<const SlidingTask> task, const PlannerParams &params,
                                         const Eigen::VectorXd &start, const Eigen::VectorXd &goal,
                                         const ob::PlannerTerminationCondition &ptc)
    {
        const auto started = std::chrono::steady_clock::now();
        const RobotModel &robot = *task->robot;
        if (start.size() != static_cast<long>(robot.dof()) || goal.size() != static_cast<long>(robot.dof()))
            throw std::invalid_argument("start and goal need one value per joint");
        auto ambient = jointSpace(robot);
        auto constraint = std::make_shared<SlidingConstraint>(task->robot, task->surfaceZ, params);
        auto space = std::make_shared<ob::ProjectedStateSpace>(ambient, constraint);
        space->setDelta(params.maxJointStep);
        auto si = std::make_shared<ob::ConstrainedSpaceInformation>(space);
        const auto validity = std::make_shared<SlidingValidity>(si, task, constraint);
        si->setStateValidityChecker([validity, &robot](const ob::State *state) {
            const Eigen::VectorXd q = *state->as<ob::ConstrainedStateSpace::StateType>();
            return validity->isValid(q, robot.fk(q));
        });
        si->setup();
        ob::ScopedState<> from(space), to(space);
        from->as<ob::ConstrainedStateSpace::StateType>()->copy(start);
        to->as<ob::ConstrainedStateSpace::StateType>()->copy(goal);
        auto pdef = std::make_shared<ob::ProblemDefinition>(si);
        pdef->setStartAndGoalStates(from, to);
        og::RRTConnect planner(si);
        planner.setProblemDefinition(pdef);
        planner.setup();
        PeerResult result;
        result.solved = planner.solve(ptc) == ob::PlannerStatus::EXACT_SOLUTION;
        if (result.solved)
            result.states = pdef->getSolutionPath()->as<og::PathGeometric>()->getStateCount();
        result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        return result;
    }

}  // namespace slideplan

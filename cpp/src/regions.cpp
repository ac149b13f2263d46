#include "slideplan/regions.hpp"

#include "slideplan/contact_frame.hpp"
#include "slideplan/straight_line.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace slideplan
{
    ContactRegion::ContactRegion(std::shared_ptr<const SlidingValidity> validity, const PlannerParams &params)
      : validity_(std::move(validity)), params_(params), reach_(0.0)
    {
        const RobotModel &robot = *validity_->task().robot;
        const int tip = robot.linkIndex(robot.tipLink());
        // An upper bound of the contact frame's distance from the base: every joint origin, every
        // prismatic travel and the tip offset, end to end.
        for (const int index : robot.pathTo(tip))
        {
            const RobotLink &link = robot.links()[index];
            reach_ += link.origin.translation().norm();
            if (link.jointType == RobotLink::JointType::Prismatic)
                reach_ += link.jointIndex >= 0 ? std::abs(link.multiplier) * std::max(std::abs(robot.lowerLimits()(link.jointIndex)),
                                                                                      std::abs(robot.upperLimits()(link.jointIndex))) +
                                                     std::abs(link.offset)
                                               : std::abs(link.offset);
        }
        reach_ += robot.tipOffset().translation().norm();
    }

    bool ContactRegion::sample(std::mt19937_64 &rng, const Eigen::VectorXd &seed, Eigen::VectorXd &q,
                               const ompl::base::PlannerTerminationCondition &ptc) const
    {
        const SlidingTask &task = validity_->task();
        std::uniform_real_distribution<double> yaw(-M_PI, M_PI), depth(params_.dzMin, params_.dzMax);
        Eigen::Vector2d point;
        if (!samplePoint(rng, point))
            return false;
        Eigen::Isometry3d target = Eigen::Isometry3d::Identity();
        target.linear() = contactRotation(yaw(rng), params_.beta0);
        target.translation() << point, task.surfaceZ - depth(rng);
        return reach(target, rng, seed, q, ptc);
    }

    bool ContactRegion::reach(const Eigen::Isometry3d &target, std::mt19937_64 &rng, const Eigen::VectorXd &seed,
                              Eigen::VectorXd &q, const ompl::base::PlannerTerminationCondition &ptc) const
    {
        const SlidingTask &task = validity_->task();
        if ((target.translation() - task.robot->basePose().translation()).norm() > reach_)
            return false;
        IkOptions options = contactIkOptions(*task.robot);
        options.maxAttempts = params_.rootIkAttempts;
        options.positionTolerance = options.orientationTolerance = 0.1 * params_.projectionTolerance;
        options.stop = [&ptc] { return ptc(); };
        options.accept = [this](const Eigen::VectorXd &solution) { return acceptable(solution); };
        return task.robot->ik(target, seed, rng, q, options) && validity_->isValid(q, task.robot->fk(q));
    }

    bool ContactRegion::acceptable(const Eigen::VectorXd &) const
    {
        return true;
    }

    StartRegion::StartRegion(std::shared_ptr<const SlidingValidity> validity, const PlannerParams &params)
      : ContactRegion(std::move(validity), params)
    {
        const SlidingTask &task = validity_->task();
        const Eigen::VectorXd distance = (task.objectXY.rowwise() - task.objectCom.transpose()).rowwise().norm();
        // Measured from the closest point, so that an object whose centre of mass lies off its material
        // (a crescent, a ring) keeps the contacts nearest to it.
        const double limit = params_.contactRadius > 0.0 ? distance.minCoeff() + params_.contactRadius
                                                         : std::numeric_limits<double>::infinity();
        for (Eigen::Index i = 0; i < distance.size(); ++i)
            if (distance(i) <= limit)
                candidates_.push_back(i);
    }

    bool StartRegion::acceptable(const Eigen::VectorXd &q) const
    {
        const RobotModel &robot = *validity_->task().robot;
        const Eigen::Isometry3d tip = robot.fk(q);
        // An invalid state is the caller's to reject (as without the check: the same draws, the same plans);
        // the line is solved for valid ones only, a few in a tree's growth.
        if (!params_.liftCheck || !validity_->isValid(q, tip))
            return true;
        const double top = validity_->task().surfaceZ;
        // From the seed only (one attempt: a restart would jump branches), as slideplan.motions rises.
        IkOptions near = contactIkOptions(robot);
        near.maxAttempts = 1;
        const double rise = std::max(tip.translation().z(), top) + params_.approachHeight - tip.translation().z();
        return straightLine(robot, q, tip, Eigen::Vector3d(0.0, 0.0, rise), near).has_value();
    }

    bool StartRegion::samplePoint(std::mt19937_64 &rng, Eigen::Vector2d &point) const
    {
        std::uniform_int_distribution<std::size_t> index(0, candidates_.size() - 1);
        point = validity_->task().objectXY.row(candidates_[index(rng)]).transpose();
        return true;
    }

    bool GoalRegion::samplePoint(std::mt19937_64 &rng, Eigen::Vector2d &point) const
    {
        const SupportSurface &table = *validity_->task().table;
        const Eigen::Vector2d low = table.vertices().colwise().minCoeff(), high = table.vertices().colwise().maxCoeff();
        std::uniform_real_distribution<double> x(low.x(), high.x()), y(low.y(), high.y());
        constexpr int kTries = 64;  // acceptance ~ band area / bounding box area: about 0.2 on our tables
        for (int i = 0; i < kTries; ++i)
        {
            point = Eigen::Vector2d(x(rng), y(rng));
            const double distance = table.signedDistance(point);
            if (distance > 0.0 && distance <= params_.dGoal)
                return true;
        }
        return false;
    }

}  // namespace slideplan

#include "slideplan/regions.hpp"

#include "slideplan/contact_frame.hpp"

#include <algorithm>
#include <cmath>
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

    bool ContactRegion::sample(std::mt19937_64 &rng, const Eigen::VectorXd &seed, Eigen::VectorXd &q) const
    {
        const SlidingTask &task = validity_->task();
        std::uniform_real_distribution<double> yaw(-M_PI, M_PI), depth(params_.dzMin, params_.dzMax);
        Eigen::Vector2d point;
        if (!samplePoint(rng, point))
            return false;
        Eigen::Isometry3d target = Eigen::Isometry3d::Identity();
        target.linear() = contactRotation(yaw(rng), params_.beta0);
        target.translation() << point, task.surfaceZ - depth(rng);
        if ((target.translation() - task.robot->basePose().translation()).norm() > reach_)
            return false;
        IkOptions options;
        options.maxAttempts = params_.rootIkAttempts;
        options.positionTolerance = options.orientationTolerance = 0.1 * params_.projectionTolerance;
        return task.robot->ik(target, seed, rng, q, options) && validity_->isValid(q, task.robot->fk(q));
    }

    bool StartRegion::samplePoint(std::mt19937_64 &rng, Eigen::Vector2d &point) const
    {
        const Polygon2 &cloud = validity_->task().objectXY;
        std::uniform_int_distribution<long> index(0, cloud.rows() - 1);
        point = cloud.row(index(rng)).transpose();
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
